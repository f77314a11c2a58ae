"""`python3 -m scripts.bench selftest`: the harness's rules checked on made-up numbers, files and fake
configurations, without running any tool (the equal-time loop runs with renders that only return figures)."""
import argparse
import os
import sys
import tempfile

from . import costs, ladder, measure, mitsuba_xml, plots, published, references, tier, tools

CHECKS = []


def check(f):
    CHECKS.append(f)
    return f


def expect(cond, what):
    if not cond:
        raise AssertionError(what)


def raises(exc, f, *args):
    try:
        f(*args)
    except exc:
        return True
    return False


@check
def median_rule():
    xs = [dict(relmse=r, total=t, id=i) for i, (r, t) in enumerate([(0.1, 10), (0.3, 10), (0.2, 10)])]
    expect(measure.median_render(xs)["id"] == 2, "odd count: the middle render by relMSE x total")
    # relMSE x total decides, not relMSE alone: 0.1 x 40 = 4 is the largest product.
    xs = [dict(relmse=0.1, total=40, id=0), dict(relmse=0.2, total=10, id=1), dict(relmse=0.3, total=10, id=2)]
    expect(measure.median_render(xs)["id"] == 2, "ordered by relMSE x total")
    xs = [dict(relmse=r, total=1, id=i) for i, r in enumerate([4, 1, 3, 2])]
    expect(measure.median_render(xs)["id"] == 3, "even count: the lower of the middle two (relMSE 2)")
    expect(measure.median_render(xs[:1])["id"] == 0, "one render is its own median")
    expect(raises(ValueError, measure.median_render, []), "no renders is an error")


@check
def equal_time_budget():
    expect(measure.render_seconds(30, 0) == 30, "unguided renders the whole budget")
    expect(abs(measure.render_seconds(30, 12.5) - 17.5) < 1e-12, "guided renders budget - preprocessing")
    expect(measure.render_seconds(10, 10) is None and measure.render_seconds(10, 12) is None,
           "nothing left to render: skipped")


@check
def interleaving():
    expect(measure.interleaved("abc", 0) == list("abc") and measure.interleaved("abc", 1) == list("cba")
           and measure.interleaved("abc", 2) == list("abc"), "order reversed on every other repeat")


@check
def efficiencies():
    u = dict(relmse=0.04, total=10.0, relmse_reference_noise=0.01)
    x = dict(relmse=0.02, total=10.0, relmse_reference_noise=0.01)
    expect(abs(measure.efficiency(u) - 2.5) < 1e-12, "efficiency = 1 / (relMSE x seconds)")
    expect(abs(measure.efficiency_ratio(x, u) - 2.0) < 1e-12, "plain ratio 0.04 / 0.02")
    expect(abs(measure.efficiency_ratio(x, u, clean=True) - 3.0) < 1e-12, "noise removed: 0.03 / 0.01")
    expect(measure.efficiency_ratio(dict(x, relmse_reference_noise=None), u, clean=True) is None,
           "no variance layers: no clean ratio")
    expect(measure.efficiency_ratio(dict(x, relmse_reference_noise=0.03), u, clean=True) is None,
           "reference noise above the relMSE: no clean ratio")


@check
def seed_spread_arithmetic():
    import numpy as np
    a = {"k": [np.zeros((2, 2)), np.full((2, 2), 2.0)]}
    rv, t, eff = measure.seed_spread(a, {"k": [1.0, 3.0]})["k"]
    expect(abs(rv - 2.0 / 1.01) < 1e-12, "variance 2 over mean^2 + 0.01 = 1.01, got %r" % rv)
    expect(t == 2.0 and abs(eff - 1.0 / (rv * 2.0)) < 1e-12, "median seconds and efficiency")


@check
def tables():
    lines = measure.md_table(["a", "b"], [[1, "x"], ["2", 3.5]])
    expect(lines == ["| a | b |", "|---|---|", "| 1 | x |", "| 2 | 3.5 |"], "Markdown table: %r" % lines)
    expect(raises(ValueError, measure.md_table, ["a", "b"], [[1]]), "a short row is an error")


@check
def manifests():
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "ref.exr.manifest")
        fields = dict(scene="scenes/x.xml", scene_fingerprint="abc123", resolution="32x32", kind="unguided 2048 spp",
                      command="build/bin/render scenes/x.xml -o ref.exr --set mode=nee+bsdf")
        measure.write_text(p, measure.format_manifest(fields))
        expect(measure.read_manifest(p) == fields, "manifest round trip: %r" % measure.read_manifest(p))
        expect(not os.path.exists(p + ".tmp"), "no temporary left behind")
        expect(measure.read_manifest(os.path.join(d, "missing")) == {}, "a missing manifest reads as {}")


@check
def reference_up_to_date():
    """A reference is kept only while its scene's fingerprint, its size and its kind match its manifest
    (the fingerprint, which needs a render, is made up here)."""
    real = tools.scene_fingerprint
    tools.scene_fingerprint = lambda scene: {"a.xml": "f1", "b.xml": "f2"}[scene]
    try:
        with tempfile.TemporaryDirectory() as d:
            ref = os.path.join(d, "r.exr")
            expect(not references.up_to_date(ref, "a.xml", "32x32", "unguided 16 spp"), "no file: not up to date")
            open(ref, "w").close()
            measure.write_text(ref + ".manifest", measure.format_manifest(dict(
                scene="a.xml", scene_fingerprint="f1", resolution="32x32", kind="unguided 16 spp")))
            expect(references.up_to_date(ref, "a.xml", "32x32", "unguided 16 spp"), "all match: up to date")
            expect(not references.up_to_date(ref, "b.xml", "32x32", "unguided 16 spp"), "scene content changed")
            expect(not references.up_to_date(ref, "a.xml", "64x64", "unguided 16 spp"), "size changed")
            expect(not references.up_to_date(ref, "a.xml", "32x32", "guided 300s"), "kind changed")
    finally:
        tools.scene_fingerprint = real
    spec = references.guided_seconds(300, "auto")
    expect(spec["kind"] == "guided 300s, connections auto" and "connect=auto" in spec["settings"]
           and "sampler=independent" in spec["settings"], "guided reference spec %r" % spec)
    expect(references.unguided_spp(2048)["kind"] == "unguided 2048 spp", "the kind the old manifests carry")


@check
def load_records():
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "loadavg")
        with open(p, "w") as f:
            f.write("1.50 0.75 0.25 3/456 7890\n")
        r = measure.load_now(p)
        expect(r["load"] == [1.5, 0.75, 0.25] and r["nproc"] >= 1, "load record %r" % r)
    xs = [dict(load_start=dict(load=[1.0, 0, 0], nproc=2), load_end=dict(load=[3.0, 0, 0], nproc=2))]
    s = measure.load_summary(xs)
    expect("median 2.0" in s and "range 1.0-3.0" in s and "nproc 2" in s, "load summary %r" % s)


@check
def film_sizes():
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "film.xml"), "w") as f:
            f.write('<scene><sensor><film type="hdrfilm"><integer name="width" value="640"/>'
                    '<integer name="height" value="360"/></film></sensor></scene>')
        with open(os.path.join(d, "s.xml"), "w") as f:
            f.write('<scene version="0.5.0"><include filename="film.xml"/></scene>')
        with open(os.path.join(d, "plain.xml"), "w") as f:
            f.write('<scene version="0.5.0"/>')
        expect(measure.film_size(os.path.join(d, "s.xml")) == (640, 360), "film size through an include")
        expect(measure.scaled_resolution(os.path.join(d, "s.xml"), 0.05) == "32x18", "scaled resolution")
        expect(measure.film_size(os.path.join(d, "plain.xml")) == (768, 576), "Mitsuba's default film")


@check
def commands():
    c = tools.render_cmd("s.xml", "o.exr", atlas="a.h5", seconds=2.5, resolution="32x32", seed=7,
                         settings=["pilot=off", "mode=nee+bsdf+cache"])
    expect(c[1:3] == ["s.xml", "-o"] and c[c.index("--time") + 1] == "2.500" and "--spp" not in c,
           "render --time: %r" % c)
    expect(c[c.index("--atlas") + 1] == "a.h5" and c.count("--set") == 2 and "pilot=off" in c, "settings as --set")
    expect(raises(ValueError, tools.render_cmd, "s", "o") and raises(ValueError, tools.render_cmd, "s", "o", None, 1, 1),
           "exactly one of spp and seconds")
    expect(raises(ValueError, tools.sets, ["mode"]), "a setting without '=' is an error")
    p = tools.place_caches_cmd("s.xml", "p.h5", "c.h5", "32x32", ["cache-count=10"])
    expect(p[p.index("--photon-map") + 1] == "p.h5" and "--resolution" in p, "place-caches: %r" % p)
    per = tools.split_stages(["min-caustic-share=0", "gather-count=10", "photon-paths=100"])
    expect(per == {"trace-photons": ["min-caustic-share=0", "photon-paths=100"], "place-caches": ["min-caustic-share=0"],
                   "fill-caches": ["gather-count=10"]}, "settings reach their stages: %r" % per)
    expect(raises(SystemExit, tools.split_stages, ["no-such=1"]), "an unknown preprocessing setting is an error")
    expect(tools.mode_settings("nee+bsdf") == (False, ["mode=nee+bsdf"]) and tools.mode_settings("auto") == (True, [])
           and tools.mode_settings("nee+cache") == (True, ["pilot=off", "mode=nee+cache"]), "modes as settings")
    expect(raises(ValueError, tools.mode_settings, "guided"), "an unknown mode is an error")


@check
def readings():
    # inspect-caches' summary lines (tools/inspect-caches/inspect.cpp: describe_cache_atlas)
    text = ("caches                  4000\nusable                  3990\n"
            "map resolution          32 x 32 (0.01227 sr per texel)\nrender's table          16.0 MiB (16777216 bytes)\n")
    expect(tools.parse_inspect(text) == (4000, 32, 16777216), "inspect-caches summary %r" % (tools.parse_inspect(text),))
    expect(costs.parse_bench_rays("bench-rays: s.xml: 12.345 Mrays/s (median of 3)") == 12.345, "bench-rays' rate")


def fake_config(name, prep, calls, relmse_of):
    def render(out, seconds, seed):
        calls.append((name, round(seconds, 6), seed))
        return dict(render_wall=seconds, relmse=relmse_of(name, seed), relmse_trimmed=0.0, spp=1,
                    sampling_seconds=seconds)
    return dict(name=name, prep=prep, render=render, settings=[])


@check
def equal_time_loop():
    calls = []
    rel = {("u", 7): 0.4, ("u", 8): 0.2, ("u", 9): 0.3, ("g", 7): 0.1, ("g", 8): 0.3, ("g", 9): 0.2}
    configs = [fake_config("u", 0.0, calls, lambda n, s: rel[(n, s)]),
               fake_config("g", 5.0, calls, lambda n, s: rel[(n, s)])]
    with tempfile.TemporaryDirectory() as d:
        cells = ladder.equal_time(configs, [4.0, 10.0], 3, d, log=lambda *_: None)
    expect(calls == [("u", 4.0, 7), ("u", 10.0, 7), ("g", 5.0, 7), ("u", 4.0, 8), ("g", 5.0, 8), ("u", 10.0, 8), ("u", 4.0, 9),
                     ("u", 10.0, 9), ("g", 5.0, 9)], "order, budgets and seeds: %r" % calls)
    expect("skipped" in cells[("g", 4.0)][0], "preprocessing above the budget is skipped")
    g = cells[("g", 10.0)]
    expect([x["total"] for x in g] == [10.0, 10.0, 10.0], "guided total = render + preprocessing")
    expect(all(x["load_start"]["nproc"] >= 1 and "load_end" in x for x in g), "load at each cell's start and end")
    rows = ladder.cell_rows(cells, ["u", "g"], [4.0, 10.0])
    expect([r["name"] for r in rows] == ["u", "g", "u", "g"], "rows per budget and config")
    expect(rows[3]["relmse"] == 0.2 and rows[3]["seed"] == 9, "median render of g at 10 s: relMSE 0.2 (seed 9)")
    expect(rows[2]["relmse"] == 0.3 and rows[2]["all_relmse"] == [0.4, 0.2, 0.3], "u at 10 s: the median 0.3")
    table = ladder.settings_table([dict(rows[2], flags="--set mode=nee+bsdf"), dict(rows[3], flags="")], "u")
    expect(table[3].split(" | ")[6] == "**1.50**", "settings table ratio 0.3 / 0.2: %r" % table[3])


@check
def tier_options():
    a = argparse.Namespace(tier="quick", scale=None, budgets=None, modes=None, scenes="", only="ring mi")
    scale, budgets, modes, scenes = tier.settings_of(a)
    expect(scale == 0.5 and budgets == [6.0, 12.0, 24.0] and modes[0] == "nee+bsdf", "quick tier defaults")
    expect([n for n, _ in scenes] == ["ring", "mi"], "--only keeps the set's order: %r" % scenes)
    expect(raises(SystemExit, tier.settings_of, argparse.Namespace(**dict(vars(a), only="nope"))),
           "--only of an unknown scene is an error")
    expect(raises(SystemExit, tier.settings_of, argparse.Namespace(**dict(vars(a), modes="nee+bsdf,x"))),
           "an unknown mode is an error")


@check
def report_tables_and_plots():
    md = ["## Run time against error", "", "### `box` (32x32, reference: unguided 16 spp, 16 spp)", "",
          "| budget (s) | nee+bsdf relMSE (spp) | auto relMSE (spp) | eff. ratio | ref. noise removed |",
          "|---|---|---|---|---|", "| 1 | 0.5 (10) | 0.25 (8) | 2.00 | n/a |", "| 2 | 0.2 (20) | n/a | n/a | n/a |", ""]
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "quick.md")
        with open(p, "w") as f:
            f.write("\n".join(md))
        s = plots.read_report_tables(p)
        expect(s == {"box": ("box (32x32)", {"nee+bsdf": [(1.0, 0.5), (2.0, 0.2)], "auto": [(1.0, 0.25)]})},
               "tables read back: %r" % s)
        expect(plots.plot("box", s["box"][1], os.path.join(d, "box")), "a plot is drawn")
        expect(os.path.getsize(os.path.join(d, "box.png")) > 0 and os.path.getsize(os.path.join(d, "box.svg")) > 0,
               "PNG and SVG written")
        expect(not plots.plot("none", {"a": [(0, 1)]}, os.path.join(d, "none")), "nothing positive: no plot")


# A made-up published scene: a guided integrator with a commented-out one, $defaults, a nested <default>
# inside a shape, a self-closing film.
_PUB = """<scene version="0.5.0">
	<default name="spp" value="64"/>
	<default name="w" value="640"/>
	<!-- <integrator type="bdpt"/> -->
	<integrator type="guided_path">
		<integer name="maxDepth" value="10"/>
		<integer name="rrDepth" value="$rr"/>
		<!--<integer name="maxDepth" value="40"/>-->
		<string name="budgetType" value="spp"/>
	</integrator>
	<default name="rr" value="7"/>
	<sensor type="perspective">
		<sampler type="independent">
			<integer name="sampleCount" value="$spp"/>
		</sampler>
		<film type="hdrfilm"/>
	</sensor>
	<shape type="sphere"><default name="x" value="1"/><bsdf type="diffuse"/></shape>
</scene>
"""


@check
def mitsuba_variant():
    import xml.etree.ElementTree as ET
    info = mitsuba_xml.inspect(_PUB)
    expect((info["width"], info["height"]) == (768, 576), "film size: Mitsuba's defaults where unset")
    expect((info["maxDepth"], info["rrDepth"]) == ("10", "7"), "depths with $names resolved from <default>s")
    v = mitsuba_xml.variant(_PUB, 32, 5, 128, 96)
    root = ET.fromstring(v)
    integ = root.findall("integrator")
    expect(len(integ) == 1 and integ[0].get("type") == "path", "one stock path integrator")
    expect({i.get("name"): i.get("value") for i in integ[0]} == {"maxDepth": "10", "rrDepth": "7"},
           "the scene's maxDepth and rrDepth kept, nothing else")
    s = {i.get("name"): i.get("value") for i in root.find("sensor/sampler")}
    expect(s == {"sampleCount": "32", "seed": "5"}, "sampleCount and seed set")
    f = {i.get("name"): i.get("value") for i in root.find("sensor/film")}
    expect(f == {"width": "128", "height": "96", "componentFormat": "float32"}, "film size set, float32")
    expect("<!-- <integrator type=\"bdpt\"/> -->" in v, "comments kept as published")
    shape_v = v[v.index("<shape"):]
    expect(shape_v == _PUB[_PUB.index("<shape"):], "the rest of the file unchanged")
    # without an integrator: path with Mitsuba's defaults, after the leading <default>s only
    bare = _PUB.replace(_PUB[_PUB.index("\t<!-- <integrator"):_PUB.index("\t<default name=\"rr\"")], "")
    v = mitsuba_xml.variant(bare.replace('version="0.5.0"', 'version="0.6.0"'), 8, 1, 64, 48)
    root = ET.fromstring(v)
    expect(root.get("version") == "0.5.0", "a 0.6 scene is written as 0.5.0 (Mitsuba 0.5.0 refuses 0.6)")
    expect([c.tag for c in root][:4] == ["default"] * 3 + ["integrator"], "inserted after the scene's defaults")
    expect({i.get("name"): i.get("value") for i in root.find("integrator")} == {"maxDepth": "-1", "rrDepth": "5"},
           "no integrator: path with Mitsuba's defaults")
    expect(raises(mitsuba_xml.SceneError, mitsuba_xml.variant, "<scene><shape type='obj'/></scene>", 1, 1, 8, 8),
           "no sensor: an error")


@check
def published_noise():
    import numpy as np
    rng = np.random.default_rng(3)
    truth = np.full((64, 64, 3), 0.5)
    a = truth + rng.normal(0, 0.1, truth.shape)
    b = truth + rng.normal(0, 0.1, truth.shape)
    se = published.se_from_pair(a, b)
    expect(all(abs(s / (0.1 / 64) - 1) < 0.1 for s in se), "SE of one render's mean = sigma / sqrt(n)")
    expect(abs(published.relmse(a, truth) / (0.01 / 0.26) - 1) < 0.05, "relMSE: squared error over r^2 + 0.01")
    expect(abs(published.rel_se_max([1.0, 0.5, 1e-6], [0.01, 0.01, 1.0]) - 0.02) < 1e-12,
           "the largest relative SE over channels that carry light")
    expect(published.scene_name("/x/ipg/torus/scene.available.xml") == "torus"
           and published.scene_name("/x/ppg/cbox/cbox.available.xml") == "cbox", "scene names")


def cmd_selftest(_):
    failed = 0
    for f in CHECKS:
        try:
            f()
            print("ok      %s" % f.__name__)
        except AssertionError as e:
            failed += 1
            print("FAILED  %s: %s" % (f.__name__, e))
    print("%d of %d checks passed" % (len(CHECKS) - failed, len(CHECKS)))
    sys.exit(1 if failed else 0)
