"""Benchmarks at equal samples per pixel, where the render's own seconds and counters are the figures:
`cost` (where the per-sample cost of guided rendering comes from), `resolution` (map resolution against
noise per sample) and `throughput` (render's rays per second against raw Embree, bench-rays)."""
import os
import re
import shlex
import statistics
import sys

from . import measure, references, tools

COST_SCENES = [("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml"),
               ("cbox_spiegelboxen", "scenes/thesis/cbox_spiegelboxen.xml"),
               ("bidir", "scenes/thesis/veach_bidir/bidir.xml"), ("ring", "scenes/thesis/metal_ring/ring.xml")]
GUIDED = ["pilot=off", "mode=nee+bsdf+cache"]
# unguided: the baseline; rr01: the same with the deep setting's roulette (survival below throughput 0.1
# only); first: guiding the first non-specular vertex; every: every vertex with roulette below 0.1.
COST_SETTINGS = [("unguided", False, ["mode=nee+bsdf"]),
                 ("rr01", False, ["mode=nee+bsdf", "rr-threshold=0.1"]),
                 ("first", True, GUIDED + ["guide-vertices=1"]),
                 ("every", True, GUIDED + ["guide-vertices=0", "rr-threshold=0.1"])]
# scene, the guided setting the pilot picked there with 16x16 maps, extra map resolutions tried
RESOLUTION_CASES = [("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", ["guide-vertices=0", "rr-threshold=0.1"], [24, 64]),
                    ("cbox_spiegelboxen", "scenes/thesis/cbox_spiegelboxen.xml", ["guide-vertices=0", "rr-threshold=0.1"], []),
                    ("ring", "scenes/thesis/metal_ring/ring.xml", ["guide-vertices=1"], []),
                    ("bidir", "scenes/thesis/veach_bidir/bidir.xml", ["guide-vertices=1"], [])]
THROUGHPUT_SCENES = ["cbox_kugeln.xml", "cbox_nur_box.xml", "cbox_spiegelboxen.xml", "cbox_diffuse_boxes.xml",
                     "veach_bidir/bidir.xml", "veach_mi/mi.xml", "veach_mi/mi_ohne_bretter.xml", "metal_ring/ring.xml"]


def head(title, what):
    return ["## " + title, "", "`python3 -m scripts.bench %s`, %s, nproc %d. %s" % (
        shlex.join(sys.argv[1:]), measure.today(), measure.nproc(), what), ""]


def only(items, a):
    names = set(filter(None, a.only.split(",")))
    chosen = [x for x in items if not names or x[0] in names]
    if not chosen:
        raise SystemExit("bench: no scene selected")
    return chosen


def ratio(a, b):
    return "%.2fx" % (a / b) if b else "n/a"


def cmd_cost(a):
    """Per scene the render's own seconds of four settings at equal spp, median of --repeats interleaved
    runs, and rays, cache lookups per sample (the seed-1 render's counters: they depend on the seed, not
    on the machine). Caches: the tools' defaults with min-caustic-share=0 (forced)."""
    t_rows, r_rows, loads = [], [], []
    for name, scene in only(COST_SCENES, a):
        res = a.resolution or measure.scaled_resolution(scene, a.scale)
        out = os.path.join(a.out, name)
        tools.preprocess(scene, out, a.prep_set + ["min-caustic-share=0"])
        atlas = os.path.join(out, "atlas.h5")
        t, meta = {}, {}
        for rep in range(a.repeats):
            for key, guided, settings in measure.interleaved(COST_SETTINGS, rep):
                img = os.path.join(out, key + ".exr")
                l0 = measure.load_now()
                tools.run(tools.render_cmd(scene, img, atlas=atlas if guided else None, spp=a.spp, resolution=res,
                                           seed=rep + 1, settings=settings))
                loads.append(dict(load_start=l0, load_end=measure.load_now()))
                m = tools.metadata(img)
                t.setdefault(key, []).append(float(m["iris:seconds"]))
                if rep == 0:
                    meta[key] = m
        t = {k: statistics.median(v) for k, v in t.items()}
        t_rows.append([name] + ["%.3f" % t[k] for k, _, _ in COST_SETTINGS] + [
            ratio(t["first"], t["unguided"]), ratio(t["every"], t["unguided"]), ratio(t["rr01"], t["unguided"]),
            ratio(t["every"], t["rr01"])])
        w, h = (int(v) for v in res.split("x"))
        samples = w * h * a.spp
        rays = {k: float(meta[k].get("iris:rays", "0") or 0) for k in t}
        look = {k: float(meta[k].get("iris:cache_lookups", "0") or 0) for k in t}

        def per_ray(k):
            return ratio(t[k] / rays[k], t["unguided"] / rays["unguided"]) if rays[k] and rays["unguided"] else "n/a"
        r_rows.append([name, "%.2f" % (rays["unguided"] / samples),
                       " / ".join(ratio(rays[k], rays["unguided"]) for k in ("rr01", "first", "every")),
                       " / ".join(per_ray(k) for k in ("rr01", "first", "every")),
                       "%.2f / %.2f" % (look["first"] / samples, look["every"] / samples)])
        print(" | ".join(str(c) for c in t_rows[-1]), flush=True)
    lines = head("Per-sample cost of guided rendering, decomposed",
                 "%d spp at %s, median of %d interleaved runs (render's own seconds). Ratios are to the unguided path "
                 "tracer unless named: *paths* = unguided with roulette below 0.1 / unguided (the deep setting's "
                 "longer paths), *guiding* = every vertex / unguided with roulette below 0.1. Load: %s."
                 % (a.spp, a.resolution or "scale %g" % a.scale, a.repeats, measure.load_summary(loads)))
    lines += measure.md_table(["scene", "unguided (s)", "unguided, rr 0.1 (s)", "first vertex (s)", "every vertex (s)",
                               "first vertex", "every vertex", "paths", "guiding"], t_rows)
    lines += ["", "Rays per sample and time per ray, relative to unguided (the first table's ratio = rays x time per "
              "ray), and the cache lookups per sample:", ""]
    lines += measure.md_table(["scene", "rays/sample unguided", "rays: rr 0.1 / first / every",
                               "time per ray: rr 0.1 / first / every", "lookups/sample: first / every"], r_rows)
    measure.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)


def cmd_resolution(a):
    """Per scene an atlas per map resolution (the tools' defaults with map-resolution=R and
    min-caustic-share=0), renders at equal spp of the unguided tracer and of guiding with each atlas in the
    setting the pilot picked there, two seeds; relMSE less the reference's own noise, trimmed relMSE, render
    seconds, and efficiency 1 / (relMSE x seconds) summed over the seeds, relative to unguided."""
    rows, loads = [], []
    os.makedirs(a.out, exist_ok=True)
    try:
        common_maps = [int(r) for r in a.maps.split(",")]
    except ValueError:
        raise SystemExit("bench resolution: --maps takes comma-separated integers, got %r" % a.maps)
    for name, scene, setting, extra in only(RESOLUTION_CASES, a):
        res = a.resolution or measure.scaled_resolution(scene, 0.5)
        spp_ref = 4 * 2048 if name == "cbox_kugeln" else 2048
        ref = references.ensure(scene, os.path.join(a.ref_dir, "%s-s0.5-%dspp.exr" % (name, spp_ref)) if not a.resolution
                                else os.path.join(a.ref_dir, "%s-%s-unguided-%dspp.exr" % (name, res, a.ref_spp)),
                                res, references.unguided_spp(spp_ref if not a.resolution else a.ref_spp))
        base = None
        maps = common_maps + (extra if not a.no_extra else [])
        for r in [None] + maps:
            if r is None:
                atlas, settings, label = None, ["mode=nee+bsdf"], "unguided"
            else:
                out = os.path.join(a.out, "%s-R%d" % (name, r))
                tools.preprocess(scene, out, a.prep_set + ["map-resolution=%d" % r, "min-caustic-share=0"])
                atlas, settings, label = os.path.join(out, "atlas.h5"), GUIDED + setting, " ".join(setting)
            e, m, t, work = [], [], [], 0.0
            for seed in (3, 4):
                img = os.path.join(a.out, "%s-%s-%d.exr" % (name, r or "unguided", seed))
                l0 = measure.load_now()
                tools.run(tools.render_cmd(scene, img, atlas=atlas, spp=a.spp, resolution=res, seed=seed,
                                           settings=settings))
                loads.append(dict(load_start=l0, load_end=measure.load_now()))
                secs = float(tools.metadata(img)["iris:seconds"])
                c = tools.compare(img, ref)
                err = c["relmse"] - (c.get("relmse_reference_noise") or 0.0)
                e.append("%.4f" % err)
                m.append("%.4f" % c["relmse_trimmed"])
                t.append("%.2f" % secs)
                work += err * secs
            base = base if base is not None else work
            rows.append([name, label, "-" if r is None else "%dx%d" % (r, r), " / ".join(e), " / ".join(m),
                         " / ".join(t), ratio(base, work)])
            print(" | ".join(rows[-1]), flush=True)
    lines = head("Map resolution: noise per sample and cost",
                 "%d spp, seeds 3 and 4 (figures: seed 3 / seed 4). Atlas: the tools' defaults but map-resolution, "
                 "min-caustic-share=0; guided renders `%s` and the setting in the table. relMSE less the reference's "
                 "own noise; efficiency = 1 / (relMSE x seconds), summed over both seeds, relative to unguided. "
                 "Load: %s." % (a.spp, " ".join(tools.sets(GUIDED)), measure.load_summary(loads)))
    lines += measure.md_table(["scene", "setting", "maps", "relMSE", "trimmed relMSE", "seconds",
                               "efficiency vs unguided"], rows)
    measure.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)


def parse_bench_rays(text):
    m = re.search(r": ([0-9.]+) Mrays/s", text)
    if not m:
        raise SystemExit("bench: bench-rays printed no Mrays/s")
    return float(m.group(1))


def cmd_throughput(a):
    """Paths/s and rays/s of the unguided path tracer (median of 3 runs; the render's own seconds and ray
    counter) beside bench-rays' closest-hit rate for incoherent rays on the same scene."""
    rows, loads = [], []
    os.makedirs(a.out, exist_ok=True)
    for s in [x for x in THROUGHPUT_SCENES if not a.only or os.path.basename(x)[:-4] in a.only.split(",")]:
        scene = os.path.join("scenes/thesis", s)
        res = a.resolution or "%dx%d" % measure.film_size(scene)
        w, h = (int(v) for v in res.split("x"))
        paths, rays = [], []
        for seed in (1, 2, 3):
            img = os.path.join(a.out, "throughput.exr")
            l0 = measure.load_now()
            tools.run(tools.render_cmd(scene, img, spp=a.spp, resolution=res, seed=seed, settings=["mode=nee+bsdf"]))
            loads.append(dict(load_start=l0, load_end=measure.load_now()))
            m = tools.metadata(img)
            secs = float(m["iris:seconds"])
            paths.append(w * h * a.spp / secs / 1e6)
            rays.append(float(m.get("iris:rays", "0") or 0) / secs / 1e6)
        raw = parse_bench_rays(tools.run(tools.bench_rays_cmd(scene, a.rays, 3))[1])
        p, r = statistics.median(paths), statistics.median(rays)
        rows.append(["`%s`" % s, res, "%.3f" % p, "%.3f" % r, "%.3f" % raw, "%.0f %%" % (100 * r / raw)])
        print(" | ".join(rows[-1]), flush=True)
    lines = head("Path-tracer throughput against raw Embree",
                 "render: the unguided tracer (`--set mode=nee+bsdf`) at %d spp, the scene's own resolution and depth "
                 "settings, median of 3 runs, paths and rays per second of the render's own seconds. Raw Embree: "
                 "`bench-rays`, incoherent closest-hit rays from visible surface points in uniform random directions, "
                 "median of 3 runs. Load: %s." % (a.spp, measure.load_summary(loads)))
    lines += measure.md_table(["scene", "resolution", "Mpaths/s", "Mrays/s (render)", "Mrays/s (raw Embree)", "ratio"], rows)
    measure.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)
