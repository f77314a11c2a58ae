"""A peer in the benchmark (issue 25): iris unguided, iris guided (the default render with an atlas) and
Blender Cycles (Debian's package, CPU path tracer, scripts/cycles_render.py, its Gaussian filter matched to
iris's: filter-profile) at one ladder of total wall-clock budgets through ladder.equal_time, each against
one iris unguided reference per scene (time-bounded: the shared machine's sample rate varies several-fold).

Time: every renderer's total is the wall seconds of its whole process (iris guided: plus the preprocessing
stages' seconds; Cycles: Blender's start-up, scene construction, sync, sampling and the EXR write). Cycles
gets the budget minus the overheads a 1-sample calibration run measured as its time limit; its measured
total is what counts."""
import argparse
import json
import os
import re
import shlex
import shutil
import sys
import time

from . import filter_profile, ladder, measure, plots, references, tools
from .. import exr

LABEL = {"nee+bsdf": "iris unguided", "auto": "iris guided (default)", "cycles": "Cycles (path)"}
ORDER = ("nee+bsdf", "auto", "cycles")
# name: scene, budgets, reference seconds. The glass box's guided preprocessing took 16-45 s on the shared
# machine (2026-12-04): its ladder starts at 30 s.
SCENES = {"glass_box": ("scenes/cbox/glass_spheres.xml", "30,60,120", 420),
          "plain_box": ("scenes/cbox/empty_box.xml", "15,30,60", 180),
          "mirror_boxes": ("scenes/thesis/cbox_spiegelboxen.xml", "30", 180)}


def cycles(scene_json, out, seconds=None, spp=None, seed=7):
    """One Cycles render; its figures (wall seconds of the process and of each phase)."""
    env = dict(os.environ, CYCLES_T0="%.6f" % time.time())
    wall, stdout, stderr = tools.run(tools.cycles_cmd(scene_json, out, seconds=seconds, spp=spp, seed=seed), env=env)
    line = [l for l in stdout.splitlines() if l.startswith("cycles: ")]
    if not line or not os.path.exists(out):
        sys.exit("bench peers: Cycles wrote no result for %s\n%s\n%s" % (out, stdout[-2000:], stderr[-2000:]))
    x = json.loads(line[-1][len("cycles: "):])
    samples = [int(n) for n in re.findall(r"Sample (\d+)/\d+", stdout)]  # a lower bound; often only "Sample 0"
    x["spp"] = max(samples) if samples and max(samples) > 0 else 0
    meta = tools.metadata(out)

    def secs(v):  # Blender writes "MM:SS.ss" or "HH:MM:SS.ss"
        return sum(float(p) * 60 ** i for i, p in enumerate(reversed(v.split(":"))))
    x["cycles_sync"] = secs(meta.get("cycles.ViewLayer.synchronization_time", "0"))
    x["sampling_seconds"] = secs(meta.get("cycles.ViewLayer.render_time", "0"))
    x["wall"] = wall
    return x


def cycles_config(scene_json, reference, overhead):
    def render(out, seconds, seed):
        x = cycles(scene_json, out, seconds=max(1.0, seconds - overhead), seed=seed)
        c = tools.compare(out, reference)
        x.update(render_wall=x["wall"], relmse=c["relmse"], relmse_trimmed=c["relmse_trimmed"],
                 relmse_reference_noise=c.get("relmse_reference_noise"), mean_test=c.get("mean_test"),
                 mean_ref=c.get("mean_ref"))
        return x
    return dict(name="cycles", prep=0.0, render=render, settings=[])


def relmse(t, r):
    """compare-images' relMSE: mean over pixels and channels of (t - r)^2 / (r^2 + 0.01)."""
    import numpy as np
    return float(np.mean((t - r) ** 2 / (r * r + 0.01)))


def agreement(cells, reference):
    """Do the renderers agree with each other and with the reference at the longest budget? Per renderer
    with two or more repeats there: its own noise (half the relMSE between two repeats), its relMSE against
    the reference less the reference's share (= its own noise if neither is biased), its channel means over
    the reference, and the edge structure of its mean image's difference from the reference: relMSE on the
    5 % of pixels with the steepest reference gradient over that on the flattest 50 % (a mismatched pixel
    filter shows here first)."""
    import numpy as np
    ref, var = exr.rgb(reference), exr.variance(reference)
    lum = ref.mean(axis=2)
    gy, gx = np.gradient(lum)
    g = np.hypot(gx, gy) / (lum + 0.05)
    edge, flat = g > np.quantile(g, 0.95), g < np.quantile(g, 0.5)
    ref_noise = float(np.mean(var / (ref * ref + 0.01)))
    done = {k: v for k, v in cells.items() if v and "skipped" not in v[0]}
    if not done:
        return None
    b = max(k[1] for k in done)
    out = dict(budget=b, reference_noise=ref_noise, renderers={})
    imgs = {}
    for rn in ORDER:
        xs = sorted(done.get((rn, b), []), key=lambda x: x["repeat"])
        if len(xs) < 2:
            continue
        im = [exr.rgb(x["image"]) for x in xs]
        imgs[rn] = im
        vs_ref = float(np.mean([relmse(i, ref) for i in im]))
        mean = np.mean(im, axis=0)
        e = ((mean - ref) ** 2 / (ref * ref + 0.01)).mean(axis=2)
        out["renderers"][rn] = dict(repeats=len(im), own_noise=relmse(im[0], im[1]) / 2, vs_reference=vs_ref,
                                    less_ref_noise=vs_ref - ref_noise,
                                    channel_mean_ratio=[float(mean[..., c].mean() / ref[..., c].mean()) for c in range(3)],
                                    edge_over_flat=float(e[edge].mean() / e[flat].mean()))
    if "cycles" in imgs and "nee+bsdf" in imgs:
        r = out["renderers"]
        out["cycles_vs_unguided"] = dict(relmse=relmse(imgs["cycles"][0], imgs["nee+bsdf"][0]),
                                         expected=r["cycles"]["own_noise"] + r["nee+bsdf"]["own_noise"])
    return out


def run_scene(a, name, scene, budgets, ref_seconds, out):
    res = measure.scaled_resolution(scene, a.scale)
    ref = references.ensure(scene, os.path.join(a.ref_dir, "peer-%s-s%g-%gs.exr" % (name, a.scale, ref_seconds)), res,
                            references.unguided_seconds(ref_seconds))
    os.makedirs(out, exist_ok=True)
    scene_json = os.path.join(out, "scene.json")
    tools.run(tools.export_scene_cmd(scene, scene_json, res))
    prep, parts = tools.preprocess(scene, out, a.prep_set)
    cal = cycles(scene_json, os.path.join(out, "cycles-calibration.exr"), spp=1)
    overhead = cal["wall"] - cal["sampling_seconds"]
    print("  cycles calibration (1 spp): %.1f s wall, %.1f s not sampling" % (cal["wall"], overhead), flush=True)
    configs = [ladder.iris_config("nee+bsdf", scene, res, ref, settings=["mode=nee+bsdf"]),
               ladder.iris_config("auto", scene, res, ref, os.path.join(out, "atlas.h5"), prep),
               cycles_config(scene_json, ref, overhead)]
    cells = ladder.equal_time(configs, budgets, a.repeats, out)
    info = dict(scene=scene, name=name, resolution=res, reference=ref,
                reference_manifest=measure.read_manifest(ref + ".manifest"), prep=prep, prep_parts=parts,
                cycles_calibration=cal, cycles_overhead=overhead, repeats=a.repeats,
                rows=ladder.cell_rows(cells, list(ORDER), budgets), date=measure.today(),
                agreement=agreement(cells, ref), all=[x for v in cells.values() for x in v if "skipped" not in x])
    measure.write_text(os.path.join(out, "results.json"), json.dumps(info, indent=1))
    return info


def cmd_peers(a):
    names = a.names.replace(",", " ").split() if a.names else list(SCENES)
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        raise SystemExit("bench peers: unknown scene(s) %s (one of %s)" % (", ".join(unknown), ", ".join(SCENES)))
    if not shutil.which(tools.BLENDER):
        raise SystemExit("bench peers: %s not found; install Debian's package: apt-get install blender" % tools.BLENDER)
    runs = os.path.join(a.runs, a.report)
    os.makedirs(runs, exist_ok=True)
    # Both renderers' pixel filter, and Cycles' with the first run's width 6 px (its mismatch, since fixed).
    _, profile = filter_profile.profile(argparse.Namespace(filter="gaussian", spp=256, cycles_width=[6]))
    results = []
    for n in names:
        scene, budgets, ref_seconds = SCENES[n]
        budgets = [float(b) for b in (a.budgets or budgets).split(",")]
        results.append(run_scene(a, n, scene, budgets, a.ref_seconds or ref_seconds, os.path.join(runs, n)))
    write_report(a, results, profile)


def write_report(a, results, profile):
    output = os.path.join(a.docs, a.report + ".md")
    assets = os.path.join(a.docs, a.report)
    os.makedirs(assets, exist_ok=True)
    L = ["# Peers: iris against Blender Cycles (issue 25)", "",
         "`python3 -m scripts.bench %s`, %s, nproc %d, %d repeat(s) per cell (seeds 7 on), per cell the median render "
         "by relMSE x total seconds. Each budget renders iris unguided (`--set mode=nee+bsdf`), iris guided (`render "
         "--atlas` with the tools' defaults, its preprocessing inside the budget) and Cycles (CPU path tracer, "
         "no denoising, no adaptive sampling, no clamping, the same Gaussian pixel filter as iris: "
         "scripts/cycles_render.py says how each object is translated) one after the other, in reverse order "
         "every other repeat. Total = wall seconds of the whole process; sampling = the renderer's own sampling "
         "seconds. Efficiency = 1 / (relMSE x total). Cycles' sample counts are the last `Sample N` its progress "
         "printed (a lower bound)." % (shlex.join(sys.argv[1:]), measure.today(), measure.nproc(), a.repeats), "",
         "The pixel filter, measured on a slanted emitter edge seen directly (`python3 -m scripts.bench "
         "filter-profile`, a Gaussian CDF fitted to the edge spread):", "", "```", profile, "```", ""]
    summary = []
    for r in results:
        man, ag = r["reference_manifest"], r.get("agreement")
        by = {(x["name"], x["budget"]): x for x in r["rows"]}
        budgets = sorted({x["budget"] for x in r["rows"]})
        L += ["## %s (`%s`, %s)" % (r["name"], r["scene"], r["resolution"]), "",
              "Reference: iris unguided, %s spp in %s s; its noise share of every relMSE %s. Guided preprocessing "
              "%.1f s (%s). Cycles' overhead (1-sample run, not sampling): %.1f s. Load: %s."
              % (man.get("spp"), man.get("seconds"), "%.2g" % ag["reference_noise"] if ag else "-", r["prep"],
                 ", ".join("%s %.1f s" % kv for kv in r["prep_parts"].items()), r["cycles_overhead"],
                 measure.load_summary(r["all"])), ""]
        if ag:
            L += ["**Agreement at %g s** (unbiased renderers have relMSE against the reference less its noise = "
                  "own noise, and equal edge/flat):" % ag["budget"], ""]
            L += measure.md_table(["renderer", "repeats", "own noise", "relMSE vs reference", "less ref noise",
                                   "mean R, G, B / reference", "edge/flat"],
                                  [[LABEL[rn], g["repeats"], "%.3g" % g["own_noise"], "%.3g" % g["vs_reference"],
                                    "%.3g" % g["less_ref_noise"], " / ".join("%.4f" % v for v in g["channel_mean_ratio"]),
                                    "%.2f" % g["edge_over_flat"]] for rn in ORDER for g in [ag["renderers"].get(rn)] if g])
            cu = ag.get("cycles_vs_unguided")
            if cu:
                L += ["", "Cycles against iris unguided (first repeats): relMSE %.3g; the sum of their own noises "
                      "%.3g (ratio %.2f)." % (cu["relmse"], cu["expected"], cu["relmse"] / cu["expected"])]
            L.append("")
        rows = []
        for b in budgets:
            cy, un = by.get(("cycles", b)), by.get(("nee+bsdf", b))
            for rn in ORDER:
                x = by.get((rn, b))
                if not x or "skipped" in x:
                    rows.append(["%g" % b, LABEL[rn]] + ["-"] * 8 + [x["skipped"] if x else "not run"])
                    continue

                def vs(o, clean=False):
                    if not o or "skipped" in o:
                        return "-"
                    v = measure.efficiency_ratio(x, o, clean)
                    return "%.2fx" % v if v is not None else "-"
                rows.append(["%g" % b, LABEL[rn], "%.1f" % x["total"], "%.1f" % x["sampling_seconds"],
                             "%d" % x["spp"] if x.get("spp") else "-",
                             "%.4g (%s)" % (x["relmse"], " / ".join("%.3g" % v for v in x["all_relmse"])),
                             "%.4g" % measure.efficiency(x), vs(cy), vs(cy, True), vs(un),
                             " / ".join("%.3f" % (t / m) for t, m in zip(x.get("mean_test") or [], x.get("mean_ref") or []))])
                if rn == "auto" and cy and "skipped" not in cy:
                    summary.append((r["name"], b, x, un, cy))
        L += measure.md_table(["budget s", "renderer", "total s", "sampling s", "spp", "relMSE (kept; all)",
                               "efficiency", "vs Cycles", "vs Cycles, ref noise removed", "vs unguided",
                               "mean R,G,B / ref"], rows) + [""]
        series = {LABEL[rn]: [(x["total"], x["relmse"]) for x in r["rows"] if x["name"] == rn and "skipped" not in x]
                  for rn in ORDER}
        points = {LABEL[rn]: [(x["total"], x["relmse"]) for x in r["all"] if x["name"] == rn] for rn in ORDER}
        stem = os.path.join(assets, r["name"])
        if plots.plot(r["name"], series, stem, xlabel="total wall seconds", points=points):
            L += ["![%s: relMSE against total seconds](%s)" % (
                r["name"], os.path.relpath(stem + ".svg", os.path.dirname(output))), ""]
    if summary:
        rows = []
        for name, b, g, u, cy in summary:
            def rt(x, y, clean=False):
                v = measure.efficiency_ratio(x, y, clean) if y and "skipped" not in y else None
                return "%.2fx" % v if v is not None else "-"
            rows.append([name, "%g" % b, rt(g, cy), rt(g, cy, True), rt(g, u), rt(u, cy) if u and "skipped" not in u else "-"])
        at = next(i for i, line in enumerate(L) if line.startswith("The pixel filter, measured"))
        L[at:at] = \
            ["## Summary: iris guided (the default) at equal total time", ""] + measure.md_table(
                ["scene", "budget s", "guided vs Cycles", "same, ref noise removed", "guided vs unguided",
                 "unguided vs Cycles"], rows) + [""]
    measure.write_text(output, "\n".join(L).rstrip() + "\n")
    print("wrote " + output)
