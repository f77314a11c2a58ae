#!/usr/bin/env python3
"""Run time against error: the benchmark behind docs/BENCHMARKS.md (issue 4). Driven by pipelines/bench.mk.

Subcommands (each writes files; bench.mk decides what is stale):
  reference  an unguided long render of a scene (independent of the guiding code) with a manifest
  runs       for one scene: the guided pipeline's preprocessing once, then every mode at a ladder of
             total time budgets (preprocessing counted inside a guided budget), each compared against
             the reference; all figures in results.json
  report     tables, log-log plots (matplotlib: PNG and SVG) and image crops for every scene of a tier
  plots      re-draws the plots of committed reports from their tables (budget on the time axis)
  params     the parameter studies on one scene: one pipeline setting varied at a time, fixed guiding
             against nee+bsdf at one total budget; a markdown table per setting

The Python standard library, and matplotlib for the plots (run it with Debian's /usr/bin/python3,
which has python3-matplotlib; pipelines/bench.mk does). Times are wall seconds on this machine, measured around each
tool's whole command (scene loading and atlas loading included), so that modes are compared at equal
total cost. Efficiency = 1 / (relMSE x time); its ratio to nee+bsdf at the same budget is the headline.
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

BIN = os.environ.get("IRIS_BIN", "build/bin")


def film_size(scene):
    """Width and height of the scene's film (Mitsuba's defaults 768 x 576), also where it is in a file the
    scene <include>s (paths relative to the including file, as the loader reads them)."""
    size = [768, 576]

    def visit(path):
        try:
            root = ET.parse(path).getroot()
        except (OSError, ET.ParseError) as e:
            sys.exit("bench: cannot read the film size from %s: %s" % (path, e))
        for e in root.iter():
            if e.tag == "include":
                visit(os.path.join(os.path.dirname(path), e.get("filename")))
            elif e.tag == "film":
                for i in e.findall("integer"):
                    if i.get("name") in ("width", "height"):
                        size[i.get("name") == "height"] = int(i.get("value"))

    visit(scene)
    return size[0], size[1]


def scaled_resolution(scene, scale):
    w, h = film_size(scene)
    return max(1, round(w * scale)), max(1, round(h * scale))


def write_text(path, text):
    """Writes a file whole or not at all (a temporary beside it, renamed): an interrupted benchmark never
    leaves a half-written report, results file or manifest."""
    with open(path + ".tmp", "w") as f:
        f.write(text)
    os.replace(path + ".tmp", path)


def run(cmd, **kw):
    """Runs a command; returns its wall seconds. Raises with the command's stderr on failure."""
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    seconds = time.monotonic() - t0
    if p.returncode != 0:
        sys.exit("bench: failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stderr.strip()))
    return seconds, p.stdout, p.stderr


def metadata(exr):
    _, out, _ = run([BIN + "/compare-images", exr, "--metadata"])
    meta = {}
    for line in out.splitlines():
        k, _, v = line.partition(" ")
        meta[k] = v
    return meta


def compare(test, ref):
    _, out, _ = run([BIN + "/compare-images", test, ref, "--json"])
    return json.loads(out)


def read_manifest(path):
    try:
        with open(path) as f:
            return dict(line.rstrip("\n").split(" ", 1) for line in f if " " in line)
    except OSError:
        return {}


def scene_fingerprint(scene):
    """The fingerprint render records for a scene (a 1-pixel, 1-sample render: the scene load only)."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "fp.exr")
        run([BIN + "/render", scene, "-o", out, "--spp", "1", "--resolution", "1x1", "-q"])
        return metadata(out).get("iris:scene_fingerprint", "?")


def cmd_reference(a):
    if (a.spp > 0) == (a.guided_seconds > 0):
        raise SystemExit("bench reference: give either --spp or --guided-seconds")
    w, h = scaled_resolution(a.scene, a.scale)
    os.makedirs(os.path.dirname(a.output) or ".", exist_ok=True)
    # make asks again whenever the scene file is newer (a fresh copy of the scenes, a touch); the
    # manifest says whether the existing reference still matches the scene's content and settings.
    m = read_manifest(a.output + ".manifest")
    kind = "guided %gs" % a.guided_seconds if a.guided_seconds else "unguided %d spp" % a.spp
    if a.guided_seconds and a.connect != "off":
        kind += ", connections " + a.connect
    if (os.path.exists(a.output) and m.get("scene_fingerprint") == scene_fingerprint(a.scene)
            and m.get("resolution") == "%dx%d" % (w, h) and m.get("kind", "unguided %s spp" % m.get("spp")) == kind):
        os.utime(a.output)
        print("reference %s: up to date (same scene fingerprint, resolution and kind: %s)" % (a.output, kind))
        return
    if a.guided_seconds:
        # A guided reference: the default pipeline's own renderer with an atlas of its own seeds (not the
        # benchmark's), bounded by time. At equal time it has several times less noise than an unguided one
        # on the caustic scenes, and its variance layers let the report take that noise out of every relMSE.
        # Guided and unguided renders agree per pixel (tests/pipeline/test_guiding_unbiased.cpp); the report
        # also checks the reference against an unguided one of the same scene and size (runs --check-reference).
        # Without caustic connections (render --connect off, unless --connect says otherwise), so that the
        # reference does not rest on the newest estimator it may be judging; where the paths they join are
        # most of the image (a room lit through glass), a reference without them stays too noisy to judge
        # anything, and --connect auto lets the pilot weigh them as in the renders.
        # References take independent samples (--sampler independent):
        # only then are their variance layers unbiased estimates of their noise, which the report removes.
        prep = os.path.splitext(a.output)[0] + ".prep"
        run(["make", "-s", "-f", "pipelines/guided.mk", "SCENE=" + a.scene, "OUT=" + prep, "BIN=" + BIN,
             "SEED=1000004", "atlas"])
        cmd = [BIN + "/render", a.scene, "--atlas", os.path.join(prep, "atlas.h5"), "--mode", "auto",
               "--caustics", "auto", "--connect", a.connect, "--time", "%g" % a.guided_seconds, "--resolution", "%dx%d" % (w, h),
               "--seed", "1000005", "--variance", "--sampler", "independent", "-q", "-o", a.output]
    else:
        cmd = [BIN + "/render", a.scene, "-o", a.output, "--mode", "nee+bsdf", "--spp", str(a.spp),
               "--resolution", "%dx%d" % (w, h), "--seed", "1000003", "--variance", "--sampler", "independent", "-q"]
    seconds, _, _ = run(cmd)
    meta = metadata(a.output)
    write_text(a.output + ".manifest",
               "scene %s\n" % a.scene
               + "scene_fingerprint %s\n" % meta.get("iris:scene_fingerprint", "?")
               + "resolution %dx%d\n" % (w, h)
               + "kind %s\n" % kind
               + "spp %s\n" % meta.get("iris:spp", "?")
               + "seconds %.1f\n" % seconds
               + "version %s\n" % meta.get("iris:version", "?")
               + "command %s\n" % " ".join(cmd))
    print("reference %s: %s spp, %.0f s" % (a.output, meta.get("iris:spp"), seconds))


def add_spread_options(ap, seeds):
    """The options of the benchmarks that measure noise from the spread across seeds (bench_sampler.py,
    bench_choice.py, bench_ab.py)."""
    ap.add_argument("--out", required=True, help="folder for the renders")
    ap.add_argument("-o", "--output", required=True, help="report (Markdown)")
    ap.add_argument("--seeds", type=int, default=seeds)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--only", default="", help="comma-separated scene names")


def selected_scenes(scenes, a):
    """(entry, its render folder) for the entries of `scenes` (tuples whose first item is the scene's name)
    that --only selects, each folder created under --out."""
    only = set(filter(None, a.only.split(",")))
    for entry in scenes:
        if only and entry[0] not in only:
            continue
        out = os.path.join(a.out, entry[0])
        os.makedirs(out, exist_ok=True)
        yield entry, out


def seed_spread(images, seconds):
    """Noise from the spread across seeds. images: key -> luminance images of one scene, one per seed (every
    key estimates the same image); seconds: key -> wall times. Per key (relative variance of one render,
    median seconds, efficiency = 1 / (relative variance x seconds)); the relative variance is the variance
    across the seeds of each pixel over (mean^2 + 0.01), the mean over every render of the scene, averaged
    over the pixels. A render's own sample variance cannot stand in for it: stratified samples are not
    independent."""
    import numpy as np
    mean = np.mean([im for ims in images.values() for im in ims], axis=0)
    denom = mean * mean + 0.01
    result = {}
    for key, ims in images.items():
        rv = float(np.mean(np.var(np.array(ims), axis=0, ddof=1) / denom))
        t = statistics.median(seconds[key])
        result[key] = (rv, t, 1.0 / (rv * t))
    return result


def preprocess(scene, out, pipeline_vars):
    """Runs the pipeline's preprocessing from scratch into OUT (so that its times are this run's);
    returns (total seconds, seconds per stage) as the stages measured themselves."""
    for stage in ("photons", "caches", "atlas"):
        for ext in (".h5", ".seconds", ".params"):
            p = os.path.join(out, stage + ext)
            if os.path.exists(p):
                os.remove(p)
    run(["make", "-s", "-f", "pipelines/guided.mk", "SCENE=" + scene, "OUT=" + out, "BIN=" + BIN, "atlas"]
        + list(pipeline_vars))
    parts = {}
    for stage in ("photons", "caches", "atlas"):
        with open(os.path.join(out, stage + ".seconds")) as f:
            parts[stage] = float(f.read())
    return sum(parts.values()), parts


def atlas_caches(atlas):
    """The number of caches in an atlas (inspect-caches' summary)."""
    _, out, _ = run([BIN + "/inspect-caches", atlas])
    for line in out.splitlines():
        if line.startswith("caches "):
            return int(line.split()[1])
    raise RuntimeError("inspect-caches printed no cache count for " + atlas)


def render_and_compare(scene, out, res, seconds, reference, extra, seed=7):
    """One timed render (--time SECONDS) compared with the reference: a dict of its figures."""
    cmd = [BIN + "/render", scene, "-o", out, "--resolution", res, "--time", "%.3f" % seconds, "--seed", str(seed),
           "-q"]
    wall, _, _ = run(cmd + list(extra))
    meta = metadata(out)
    c = compare(out, reference)
    return dict(render_wall=wall, spp=int(meta["iris:spp"]), sampling_seconds=float(meta["iris:seconds"]),
                relmse=c["relmse"], relmse_trimmed=c["relmse_trimmed"], mape=c["mape"],
                relmse_reference_noise=c.get("relmse_reference_noise"),
                nonfinite=int(meta.get("iris:nonfinite_samples", "0")), decision=meta.get("iris:auto_guide", ""),
                image=out)


def cmd_runs(a):
    if a.repeats < 1:
        raise SystemExit("bench: --repeats must be >= 1, got %d" % a.repeats)
    w, h = scaled_resolution(a.scene, a.scale)
    res = "%dx%d" % (w, h)
    os.makedirs(a.out, exist_ok=True)
    # The reference must be of this scene (fingerprint) and size.
    ref_meta = metadata(a.reference)
    budgets = [float(b) for b in a.budgets.split(",")]
    modes = a.modes.split(",")
    guided_modes = [m for m in modes if m != "nee+bsdf"]
    prep, prep_parts = preprocess(a.scene, a.out, a.pipeline_vars) if guided_modes else (0.0, {})
    atlas = os.path.join(a.out, "atlas.h5")
    # The fixed guided modes show what guiding does: where the pipeline placed no caches (a scene without
    # light through specular chains, MIN_CAUSTIC), they get their own preprocessing with caches forced.
    fixed = dict(atlas=atlas, prep=prep)
    auto_caches = atlas_caches(atlas) if guided_modes else None
    if any(m != "auto" for m in guided_modes) and auto_caches == 0:
        forced = os.path.join(a.out, "forced")
        os.makedirs(forced, exist_ok=True)
        p, _ = preprocess(a.scene, forced, list(a.pipeline_vars) + ["MIN_CAUSTIC=0"])
        fixed = dict(atlas=os.path.join(forced, "atlas.h5"), prep=p)
    # With --repeats N every cell is rendered N times (seeds 7, 8, ...), the modes' order reversed on every
    # other repeat so that neither always runs second, and the cell keeps its median render by relMSE x
    # time: on a shared machine the sample rate drifts by +-10 % between renders minutes apart, which one
    # render per cell measures along with the renderer.
    cells = {}
    for r in range(a.repeats):
        for b in budgets:
            for m in (modes if r % 2 == 0 else modes[::-1]):
                suffix = "" if a.repeats == 1 else "-r%d" % (r + 1)
                out = os.path.join(a.out, "%s-%gs%s.exr" % (m.replace("+", "_"), b, suffix))
                m_atlas, m_prep = (atlas, prep) if m == "auto" else (fixed["atlas"], fixed["prep"])
                if m == "nee+bsdf":
                    m_prep = 0.0
                render_time = b - m_prep
                if render_time <= 0:
                    cells[(m, b)] = [dict(mode=m, budget=b, skipped="preprocessing alone exceeds the budget")]
                    continue
                x = render_and_compare(a.scene, out, res, render_time, a.reference,
                                       ["--atlas", m_atlas, "--mode", m] if m != "nee+bsdf" else [], seed=7 + r)
                x.update(mode=m, budget=b, prep=m_prep)
                x["total"] = x["render_wall"] + x["prep"]
                cells.setdefault((m, b), []).append(x)
                print("  %-16s %5.1f s: relMSE %.4g (%s spp)%s" % (m, b, x["relmse"], x["spp"],
                      ("  [" + x["decision"].split(":")[0] + "]") if x["decision"] else ""))
    rows = []
    for b in budgets:
        for m in modes:
            xs = cells[(m, b)]
            if "skipped" in xs[0]:
                rows.append(xs[0])
                continue
            xs = sorted(xs, key=lambda x: x["relmse"] * x["total"])
            x = dict(xs[(len(xs) - 1) // 2])
            if len(xs) > 1:
                x["repeats"] = [round(y["relmse"] * y["total"], 6) for y in xs]
            rows.append(x)
    check = None
    if a.check_reference:
        # Two independent unbiased references differ by their noise alone: the relMSE between them should
        # equal the sum of their own noise shares (each from its variance layers).
        ab, ba = compare(a.reference, a.check_reference), compare(a.check_reference, a.reference)
        check = dict(path=a.check_reference, spp=metadata(a.check_reference).get("iris:spp"), relmse=ab["relmse"],
                     expected=(ab.get("relmse_reference_noise") or 0) + (ba.get("relmse_reference_noise") or 0))
    info = dict(scene=a.scene, name=a.name, resolution=res, reference=a.reference, reference_check=check,
                reference_mode=ref_meta.get("iris:mode", "?"),
                reference_connections="--connect auto" in ref_meta.get("iris:command_line", ""),
                reference_spp=ref_meta.get("iris:spp"), prep=prep, prep_parts=prep_parts,
                atlas_bytes=os.path.getsize(fixed["atlas"]) if guided_modes else 0,
                pipeline_vars=a.pipeline_vars, rows=rows, repeats=a.repeats, date=time.strftime("%Y-%m-%d"),
                threads=os.cpu_count())
    if guided_modes:
        # Memory the renderer holds for the maps, as inspect-caches reports it.
        _, out, _ = run([BIN + "/inspect-caches", fixed["atlas"]])
        stats = dict(line.split(None, 1) for line in out.splitlines() if line.startswith(("caches ", "map ")))
        table = re.search(r"^render's table .*\((\d+) bytes\)", out, re.M)
        caches = int(stats["caches"].split()[0])
        res = int(stats["map"].split()[1])
        info["auto_caches"] = auto_caches
        info["table_bytes"] = int(table.group(1))
        info["caches"] = caches
        info["map_resolution"] = res
    write_text(os.path.join(a.out, "results.json"), json.dumps(info, indent=1))


def cmd_params(a):
    """The thesis's parameter studies at equal total time: one pipeline setting varied at a time from the
    defaults, fixed guiding (nee+bsdf+cache, so that auto's choice does not hide the setting's effect)
    against nee+bsdf at the same budget."""
    w, h = scaled_resolution(a.scene, a.scale)
    res = "%dx%d" % (w, h)
    os.makedirs(a.out, exist_ok=True)
    studies = []
    for part in a.study.split(";"):
        var, _, values = part.partition("=")
        studies.append((var.strip(), [v.strip() for v in values.split(",") if v.strip()]))
    rows, bases = [], {}
    for var, values in studies:
        # An unguided render beside each study: on a shared machine the speed drifts over minutes, and
        # each table's ratios should be to a baseline measured at about the same time.
        base = render_and_compare(a.scene, os.path.join(a.out, "nee_bsdf-%s.exr" % var), res, a.budget,
                                  a.reference, [])
        base["total"] = base["render_wall"]
        bases[var] = base
        print("  %s: nee+bsdf %.0f s: relMSE %.4g (%d spp)" % (var, a.budget, base["relmse"], base["spp"]))
        for v in values:
            prep, parts = preprocess(a.scene, a.out, ["%s=%s" % (var, v)])
            if prep >= a.budget:
                rows.append(dict(var=var, value=v, prep=prep, skipped=True))
                continue
            x = render_and_compare(a.scene, os.path.join(a.out, "%s-%s.exr" % (var, v)), res, a.budget - prep,
                                   a.reference, ["--atlas", os.path.join(a.out, "atlas.h5"), "--mode",
                                                 "nee+bsdf+cache"])
            x.update(var=var, value=v, prep=prep, prep_parts=parts, total=prep + x["render_wall"],
                     atlas_bytes=os.path.getsize(os.path.join(a.out, "atlas.h5")))
            rows.append(x)
            print("  %s=%s: prep %.2f s, relMSE %.4g (%d spp)" % (var, v, prep, x["relmse"], x["spp"]))
    eff = lambda x: 1.0 / (x["relmse"] * x["total"])  # trimmed: the same with the worst 0.1 % of pixels dropped
    lines = ["## Parameter studies: `%s` at %g s (%s)" % (a.name, a.budget, res), "",
             "`make -f pipelines/bench.mk params PARAM_SCENE=%s`, %s, %d threads. One pipeline setting "
             "(pipelines/guided.mk) is varied at a time, the others at their defaults; each guided render "
             "(`--mode nee+bsdf+cache`, fixed guiding) gets `--time` = %g s - its preprocessing, and is compared "
             "with the unguided reference (%s). Efficiency = 1 / (relMSE x total time), as a ratio to a nee+bsdf "
             "render of %g s made just before each table's renders. relMSE x spp (per-sample error) separates the "
             "quality of the guiding from its cost and from the machine's speed. One render per cell, seed 7: "
             "the rows of the default setting, repeated in every table, show the run-to-run spread."
             % (a.name, time.strftime("%Y-%m-%d"), os.cpu_count(), a.budget, a.reference, a.budget), ""]
    for var, values in studies:
        base = bases[var]
        lines += ["### %s" % var, "", "nee+bsdf: relMSE %.4g at %d spp (relMSE x spp %.3g)."
                  % (base["relmse"], base["spp"], base["relmse"] * base["spp"]), "",
                  "| %s | preprocessing (s) | atlas (MB) | spp | relMSE | relMSE x spp | trimmed relMSE | "
                  "efficiency vs nee+bsdf | same, trimmed |" % var, "|---|---|---|---|---|---|---|---|---|"]
        for x in rows:
            if x["var"] != var:
                continue
            if x.get("skipped"):
                lines.append("| %s | %.2f | | | preprocessing exceeds the budget | | | | |" % (x["value"], x["prep"]))
                continue
            lines.append("| %s | %.2f | %.1f | %d | %.4g | %.3g | %.4g | %.2f | %.2f |"
                         % (x["value"], x["prep"], x["atlas_bytes"] / 1e6, x["spp"], x["relmse"],
                            x["relmse"] * x["spp"], x["relmse_trimmed"], eff(x) / eff(base),
                            base["relmse_trimmed"] * base["total"] / (x["relmse_trimmed"] * x["total"])))
        lines.append("")
    os.makedirs(os.path.dirname(a.output) or ".", exist_ok=True)
    write_text(a.output, "\n".join(lines) + "\n")
    print("wrote %s" % a.output)


# ---- report ---------------------------------------------------------------------------------------

COLOURS = {"nee+bsdf": "#444444", "nee+bsdf+cache": "#1f77b4", "auto": "#d62728", "nee+cache": "#2ca02c",
           "bsdf+cache": "#9467bd"}


def plot(title, series, path, xlabel="total seconds (preprocessing included)"):
    """Log-log relMSE against seconds, one line per mode, with matplotlib (Debian python3-matplotlib):
    path + ".png" and path + ".svg" (path without extension)."""
    pts = [(x, y) for s in series.values() for x, y in s if x > 0 and y > 0]
    if not pts:
        return
    import matplotlib
    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=100)
    for mode, s in series.items():
        s = sorted((x, y) for x, y in s if x > 0 and y > 0)
        if s:
            ax.plot([x for x, _ in s], [y for _, y in s], marker="o", linewidth=2, markersize=4,
                    color=COLOURS.get(mode, "#000000"), label=mode)
    ax.set_xscale("log")
    ax.set_yscale("log")
    # Ticks at the measured times (15, 30, 60, 120) and at 1, 2, 5 x powers of ten of relMSE, as plain
    # numbers rather than powers of ten.
    ax.set_xticks(sorted({x for x, _ in pts}) if len({x for x, _ in pts}) <= 8 else [])
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1, 2, 5)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(xlabel)
    ax.set_ylabel("relMSE")
    ax.set_title(title)
    ax.grid(True, which="both", color="#dddddd", linewidth=0.6)
    ax.legend(loc="upper right", frameon=False)
    fig.tight_layout()
    # No timestamps in the files, so that re-plotting the same data changes nothing in git.
    fig.savefig(path + ".png", metadata={"Software": None})
    fig.savefig(path + ".svg", metadata={"Date": None, "Creator": None})
    plt.close(fig)


def read_report_tables(md):
    """The per-scene ladders of a committed report (docs/benchmarks/<report>.md, written by `report`):
    {name: (title, {mode: [(budget seconds, relMSE), ...]})}. The report keeps the budgets, not each
    render's measured total seconds (results.json, under out/bench/, not committed), so plots made from
    it put the budget on the time axis; the measured totals are within a few percent of it."""
    scenes, name, title, modes = {}, None, None, None
    for line in open(md):
        m = re.match(r"### `([^`]+)` \((\d+x\d+)", line)
        if m:
            name, title, modes = m.group(1), "%s (%s)" % (m.group(1), m.group(2)), None
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if name and line.startswith("| budget (s) |"):
            modes = [c[:-len(" relMSE (spp)")] for c in cells[1:] if c.endswith(" relMSE (spp)")]
            scenes[name] = (title, {mm: [] for mm in modes})
            continue
        if name and modes and re.match(r"\| [0-9.]+ \|", line):
            budget = float(cells[0])
            vals = [c for c in cells[1:] if re.match(r"[0-9.e+-]+ \(\d+\)$", c)]
            for mm, v in zip(modes, vals):
                scenes[name][1][mm].append((budget, float(v.split()[0])))
        elif modes and not line.startswith("|"):
            modes = None if line.strip() else modes
    return scenes


def cmd_plots(a):
    """Re-draws the plots of committed reports from their tables (no runs needed)."""
    for md in a.reports:
        tier = os.path.splitext(os.path.basename(md))[0]
        assets = os.path.join(os.path.dirname(md), tier)
        scenes = read_report_tables(md)
        if not scenes:
            sys.exit("bench.py: error: %s: no per-scene relMSE tables found" % md)
        os.makedirs(assets, exist_ok=True)
        # The report's own prefix for its files: "full-bidir.svg" in docs/benchmarks/full-ring/ too.
        prefix = "quick" if tier.startswith("quick") else "full"
        for name, (title, series) in scenes.items():
            plot(title, series, os.path.join(assets, "%s-%s" % (prefix, name)), xlabel="total seconds (the budget)")
            print("%s: %s-%s.png, .svg" % (assets, prefix, name))


def efficiency_without_reference_noise(u, x):
    """Efficiency of render x over the unguided render u with the reference's own noise (its variance
    layers) taken out of both relMSEs: on average what the ratio against the truth would be. None where
    the reference has no variance layers or its noise estimate exceeds a relMSE."""
    nu, nx = u.get("relmse_reference_noise"), x.get("relmse_reference_noise")
    if nu is None or nx is None or x["relmse"] <= nx or u["relmse"] <= nu:
        return None
    return ((u["relmse"] - nu) * u["total"]) / ((x["relmse"] - nx) * x["total"])


def cmd_report(a):
    results = []
    for d in sorted(os.listdir(a.runs)):
        p = os.path.join(a.runs, d, "results.json")
        if os.path.exists(p):
            with open(p) as f:
                results.append(json.load(f))
    os.makedirs(a.assets, exist_ok=True)
    rel_assets = os.path.relpath(a.assets, os.path.dirname(a.output))
    command = " ".join(["make -f pipelines/bench.mk", a.tier] + a.make_vars)
    repeats = results[0].get("repeats", 1) if results else 1
    per_cell = ("one render per cell" if repeats == 1 else
                "per cell the median of %d renders by relMSE x time, seeds 7 on, modes interleaved" % repeats)
    lines = ["## Run time against error (%s tier)" % a.tier, "",
             "`%s`, %s, %s threads. Every render of a scene is compared with an "
             "reference of the same size (unguided, or guided where each section says so; its own noise is part of "
             "every relMSE, so the plain ratios are conservative, and the columns 'ref. noise removed' take it out "
             "using the reference's variance layers). Time is the wall time of the whole `render` command plus, for guided "
             "modes, the preprocessing (`trace-photons` + `place-caches` + `fill-caches`); each guided render "
             "gets `--time` = budget - preprocessing. Efficiency = 1 / (relMSE x time); the ratio is taken "
             "against nee+bsdf at the same budget (> 1: the mode wins at equal time). `auto` is the default "
             "pipeline: no caches where (almost) no photon power arrives through specular chains (then an "
             "unguided render after the photon pass), elsewhere a pilot inside the budget chooses between "
             "unguided sampling, guiding the first vertex "
             "(what `nee+bsdf+cache` renders) and guiding every vertex with Russian roulette only below "
             "throughput 0.1 (0.3 elsewhere), each with or without light tracing of the caustics seen directly "
             "(`--caustics auto`, on wherever they are at least 0.1 %% of the image); the fixed guided modes "
             "do not light-trace. Each cell: %s."
             % (command, results[0]["date"] if results else "-", results[0]["threads"] if results else "-", per_cell), ""]
    summary = []
    for r in results:
        name = r["name"]
        rows = [x for x in r["rows"] if "skipped" not in x]
        for x in rows:
            # Runs recorded before compare-images estimated the reference's own noise: measured now.
            if x.get("relmse_reference_noise") is None and os.path.exists(x["image"]):
                x["relmse_reference_noise"] = compare(x["image"], r["reference"]).get("relmse_reference_noise")
        modes = []
        for x in r["rows"]:
            if x["mode"] not in modes:
                modes.append(x["mode"])
        budgets = sorted({x["budget"] for x in r["rows"]})
        by = {(x["mode"], x["budget"]): x for x in rows}
        ref_kind = "guided" if r.get("reference_mode", "nee+bsdf") != "nee+bsdf" else "unguided"
        if r.get("reference_connections"):
            ref_kind += " (caustic connections weighed by its pilot)"
        lines += ["### `%s` (%s, %s reference of %s spp)" % (name, r["resolution"], ref_kind, r["reference_spp"]), ""]
        c = r.get("reference_check")
        if c:
            lines += ["Reference checked against an independent one (`%s`, %s spp): relMSE between them %.4g, "
                      "expected from their own noise alone %.4g (ratio %.2f; 1 = they differ by noise only)."
                      % (c["path"], c["spp"], c["relmse"], c["expected"], c["relmse"] / c["expected"]
                         if c["expected"] > 0 else float("nan")), ""]
        if r["prep"]:
            pp = r["prep_parts"]
            lines.append("Preprocessing %.2f s (photons %.2f, caches %.2f, atlas %.2f); %d caches of %dx%d texels: "
                         "atlas file %.1f MB, the renderer's table %.1f MB. Pipeline settings: %s."
                         % (r["prep"], pp.get("photons", 0), pp.get("caches", 0), pp.get("atlas", 0),
                            r["caches"], r["map_resolution"], r["map_resolution"], r["atlas_bytes"] / 1e6,
                            r["table_bytes"] / 1e6, " ".join(r["pipeline_vars"]) or "pipelines/guided.mk defaults"))
            if r.get("auto_caches") == 0:
                fixed_prep = next((x["prep"] for x in rows if x["mode"] not in ("auto", "nee+bsdf")), None)
                lines[-1] += (" The default pipeline placed no caches here (less than MIN_CAUSTIC of the photon "
                              "power arrives through specular chains; where no surface has a specular lobe "
                              "trace-photons traces nothing): `auto`'s preprocessing took %.2f s to decide that "
                              "and it rendered unguided" % r["prep"])
                if fixed_prep is None:
                    lines[-1] += "."
                else:
                    lines[-1] += ("; the caches above are those of a forced preprocessing (MIN_CAUSTIC=0, "
                                  "%.2f s) for the fixed guided modes." % fixed_prep)
            lines.append("")
        head = "| budget (s) | " + " | ".join("%s relMSE (spp) | eff. ratio | ref. noise removed" % m if m != "nee+bsdf"
                                              else "%s relMSE (spp)" % m for m in modes) + " |"
        lines += [head, "|" + "---|" * (1 + sum(3 if m != "nee+bsdf" else 1 for m in modes))]
        for b in budgets:
            cells = []
            u = by.get(("nee+bsdf", b))
            for m in modes:
                x = by.get((m, b))
                if not x:
                    cells += ["n/a"] if m == "nee+bsdf" else ["n/a", "n/a", "n/a"]
                    continue
                cells.append("%.4g (%d)" % (x["relmse"], x["spp"]))
                if m != "nee+bsdf":
                    if u:
                        eff = (u["relmse"] * u["total"]) / (x["relmse"] * x["total"])
                        clean = efficiency_without_reference_noise(u, x)
                        cells += ["%.2f" % eff, "%.2f" % clean if clean is not None else "n/a"]
                    else:
                        cells += ["n/a", "n/a"]
            lines.append("| %g | %s |" % (b, " | ".join(cells)))
        lines.append("")
        # Per-sample cost at the largest budget, and the auto mode's decisions.
        bmax = budgets[-1]
        u = by.get(("nee+bsdf", bmax))
        for m in modes:
            x = by.get((m, bmax))
            if m == "nee+bsdf" or not x or not u:
                continue
            cost = (x["sampling_seconds"] / x["spp"]) / (u["sampling_seconds"] / u["spp"])
            eff = (u["relmse"] * u["total"]) / (x["relmse"] * x["total"])
            eff_trim = (u["relmse_trimmed"] * u["total"]) / (x["relmse_trimmed"] * x["total"])
            eff_clean = efficiency_without_reference_noise(u, x)
            summary.append((name, m, bmax, eff, eff_trim, eff_clean, cost, x["prep"] / bmax, x.get("decision", "")))
            lines.append("- %s at %g s: per-sample cost %.2fx nee+bsdf (sampling seconds per spp, pilot included), "
                         "preprocessing %.1f %% of the budget%s" % (m, bmax, cost, 100 * x["prep"] / bmax,
                                                                     ("; " + x["decision"]) if x.get("decision") else ""))
        lines.append("")
        series = {m: [(x["total"], x["relmse"]) for (mm, b), x in by.items() if mm == m] for m in modes}
        stem = os.path.join(a.assets, "%s-%s" % (a.tier, name))
        plot("%s (%s)" % (name, r["resolution"]), series, stem)
        lines += ["![relMSE against time, %s](%s)" % (name, os.path.join(rel_assets, os.path.basename(stem) + ".png")), ""]
        # Crops at the largest budget, beside each other: the third of the image (in a 3 x 3 grid) where
        # the unguided render is furthest from the reference, i.e. where a difference can show.
        w, h = (int(v) for v in r["resolution"].split("x"))
        cw, ch = w // 3, h // 3
        best, crop = -1.0, "%d,%d,%d,%d" % (cw, ch, 2 * cw, 2 * ch)
        u_img = by.get(("nee+bsdf", bmax), {}).get("image")
        if u_img and os.path.exists(u_img) and cw > 0 and ch > 0:
            for gy in range(3):
                for gx in range(3):
                    x0, y0, x1, y1 = gx * cw, gy * ch, gx * cw + cw, gy * ch + ch
                    masks = ["0,0,%d,%d" % (w, y0), "0,%d,%d,%d" % (y1, w, h), "0,%d,%d,%d" % (y0, x0, y1),
                             "%d,%d,%d,%d" % (x1, y0, w, y1)]
                    cmd = [BIN + "/compare-images", u_img, r["reference"], "--json"]
                    for m in masks:
                        cmd += ["--mask", m]
                    _, out, _ = run(cmd)
                    e = json.loads(out)["relmse"]
                    if e > best:
                        best, crop = e, "%d,%d,%d,%d" % (x0, y0, x1, y1)
        cells, heads = [], []
        for m in modes + ["reference"]:
            src = r["reference"] if m == "reference" else by.get((m, bmax), {}).get("image")
            if not src or not os.path.exists(src):
                continue
            png = os.path.join(a.assets, "%s-%s-%s.png" % (a.tier, name, m.replace("+", "_")))
            run([BIN + "/compare-images", src, "--srgb-png", png, "--crop", crop])
            heads.append(m)
            cells.append("![%s](%s)" % (m, os.path.join(rel_assets, os.path.basename(png))))
        lines += ["Crops at %g s (pixels %s, the ninth of the image where nee+bsdf errs most):" % (bmax, crop), "", "| " + " | ".join(heads) + " |",
                  "|" + "---|" * len(heads), "| " + " | ".join(cells) + " |", ""]
    top = ["### Summary at the largest budget", "",
           "Efficiency from relMSE, and from relMSE with the worst 0.1 % of pixels dropped (" + per_cell + ": "
           "on scenes with fireflies the plain figure swings by tens of percent between seeds, the trimmed one "
           "much less), and from relMSE less the reference's own share (estimated from the reference's "
           "variance layers: mean of var_ref / (ref^2 + 0.01); what relMSE against the truth would be, "
           "on average). `auto` shows what its pilot chose.", "",
           "| scene | mode | budget (s) | efficiency vs nee+bsdf | same, trimmed relMSE | same, reference noise "
           "removed | per-sample cost | preprocessing share | auto chose |",
           "|---|---|---|---|---|---|---|---|---|"]
    for name, m, b, eff, eff_trim, eff_clean, cost, share, decision in summary:
        top.append("| `%s` | %s | %g | %.2f | %.2f | %s | %.2fx | %.1f %% | %s |"
                   % (name, m, b, eff, eff_trim, "%.2f" % eff_clean if eff_clean is not None else "n/a", cost,
                      100 * share, decision.split(":")[0] if decision else ""))
    out = lines[:3] + [""] + top + [""] + lines[3:]
    write_text(a.output, "\n".join(out).rstrip() + "\n")
    print("wrote %s" % a.output)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("reference")
    r.add_argument("--scene", required=True)
    r.add_argument("--scale", type=float, default=1.0)
    r.add_argument("--spp", type=int, default=0, help="an unguided reference of this many spp")
    r.add_argument("--guided-seconds", type=float, default=0,
                   help="instead: a guided reference (MODE=auto, an atlas of its own seeds) of this many seconds")
    r.add_argument("--connect", choices=["off", "auto"], default="off",
                   help="caustic connections in a guided reference (default off)")
    r.add_argument("-o", "--output", required=True)
    r.set_defaults(func=cmd_reference)
    s = sub.add_parser("runs")
    s.add_argument("--scene", required=True)
    s.add_argument("--name", required=True)
    s.add_argument("--scale", type=float, default=1.0)
    s.add_argument("--budgets", required=True, help="comma-separated total seconds")
    s.add_argument("--modes", required=True, help="comma-separated: nee+bsdf, auto, nee+bsdf+cache, ...")
    s.add_argument("--reference", required=True)
    s.add_argument("--out", required=True)
    s.add_argument("--check-reference", default="",
                   help="an independent reference of the same scene and size to check --reference against")
    s.add_argument("--repeats", type=int, default=1,
                   help="renders per cell, modes interleaved; the median by relMSE x time is kept (default 1)")
    s.add_argument("pipeline_vars", nargs="*", help="VAR=value settings for pipelines/guided.mk")
    s.set_defaults(func=cmd_runs)
    t = sub.add_parser("report")
    t.add_argument("--tier", required=True)
    t.add_argument("--runs", required=True)
    t.add_argument("-o", "--output", required=True)
    t.add_argument("--assets", required=True)
    t.add_argument("make_vars", nargs="*", help="the make settings the tier was run with, for the report's command line")
    t.set_defaults(func=cmd_report)
    q = sub.add_parser("params")
    q.add_argument("--scene", required=True)
    q.add_argument("--name", required=True)
    q.add_argument("--scale", type=float, default=1.0)
    q.add_argument("--budget", type=float, required=True, help="total seconds per render")
    q.add_argument("--reference", required=True)
    q.add_argument("--study", required=True, help="VAR=v1,v2,...;VAR2=... (pipelines/guided.mk settings)")
    q.add_argument("--out", required=True)
    q.add_argument("-o", "--output", required=True)
    q.set_defaults(func=cmd_params)
    g = sub.add_parser("plots", help="re-draw a committed report's plots from its tables")
    g.add_argument("reports", nargs="+", help="docs/benchmarks/<report>.md")
    g.set_defaults(func=cmd_plots)
    a = p.parse_args()
    a.func(a)


if __name__ == "__main__":
    main()
