#!/usr/bin/env python3
"""A/B benchmark of two builds of `render`: the same scenes, modes, seeds and samples per pixel, rendered
by this checkout's build (B, $IRIS_BIN or build/bin) and by another one (A, --old-bin, e.g. a worktree of
an earlier commit built with the same CMake settings). For a change that keeps the estimator's
expectation and alters its noise or its cost (a new light sampler, a faster kernel).

Each (scene, mode, build) is rendered with several seeds, builds interleaved inside every seed so that a
busy spell of the machine hits both. Noise is the variance across the seeds of each pixel's luminance over
(mean^2 + 0.01), with the mean over every render of the scene, averaged over the pixels (bench.seed_spread):
the relative variance of one render; efficiency = 1 / (relative variance x median seconds of the render
command). The two builds must estimate the same image: the report also gives the relative difference of
their mean images, to compare with what their noise alone explains.

  git worktree add /tmp/old <commit> && cmake -S /tmp/old -B /tmp/old/build -DCMAKE_BUILD_TYPE=Release \\
      && cmake --build /tmp/old/build --target render
  scripts/bench_ab.py --old-bin /tmp/old/build/bin --what "change" --out out/bench/ab -o docs/benchmarks/x.md
"""
import argparse
import datetime
import os
import shlex
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench  # noqa: E402
import exr  # noqa: E402

# Scene, resolution, and the modes measured. The guided settings are what render --mode auto chose on
# these scenes in docs/benchmarks/targets-connect.md, fixed so that every seed renders the same estimator.
GUIDED_EVERY = ["--mode", "nee+bsdf+cache", "--guide-vertices", "0", "--rr-threshold", "0.1", "--caustics", "on",
                "--connect", "on"]
SCENES = [
    ("cbox_nur_box", "scenes/thesis/cbox_nur_box.xml", "256x256", [("nee+bsdf", [])]),
    ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256", [
        ("nee+bsdf", []),
        ("guided", GUIDED_EVERY + ["--light-paths", "0.15"]),
    ]),
    ("bidir", "scenes/thesis/veach_bidir/bidir.xml", "384x288", [
        ("nee+bsdf", []),
        ("guided", GUIDED_EVERY + ["--light-paths", "0.15"]),
    ]),
    ("door", "scenes/door/door.xml", "240x160", [("nee+bsdf", [])]),
    ("panel_box", "scenes/cbox/panel_box.xml", "256x256", [("nee+bsdf", [])]),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old-bin", required=True, help="bin folder of build A (the baseline)")
    ap.add_argument("--what", required=True, help="one line: what B changes, for the report's title")
    bench.add_spread_options(ap, seeds=6)
    ap.add_argument("--spp", type=int, default=64)
    a = ap.parse_args()
    if a.seeds < 2 or a.spp < 1:
        sys.exit("bench_ab: needs --seeds >= 2 and --spp >= 1")
    if not os.path.isfile(os.path.join(a.old_bin, "render")):
        sys.exit("bench_ab: no render in --old-bin %s" % a.old_bin)
    import numpy as np
    builds = (("A", a.old_bin), ("B", bench.BIN))
    rows = []
    for (name, scene, res, modes), out in bench.selected_scenes(SCENES, a):
        if any(m != "nee+bsdf" for m, _ in modes):
            bench.run(["make", "-s", "-f", "pipelines/guided.mk", "SCENE=" + scene, "OUT=" + out, "BIN=" + bench.BIN,
                       "RESOLUTION=" + res, "atlas"])
        for mode, extra in modes:
            images, seconds = {}, {}
            for seed in range(1, a.seeds + 1):
                for build, bindir in (builds if seed % 2 else builds[::-1]):
                    path = os.path.join(out, "%s-%s-%d.exr" % (mode.replace("+", "_"), build, seed))
                    # B's seeds differ from A's: with the same seeds the two images would share their camera
                    # paths, and the difference of their means would not test that they estimate one image.
                    cmd = [bindir + "/render", scene, "-o", path, "--spp", str(a.spp), "--resolution", res, "--seed",
                           str(seed + (1000 if build == "B" else 0)), "-t", str(a.threads), "-q",
                           "--no-scene-warnings"] + extra
                    if mode != "nee+bsdf":
                        cmd += ["--atlas", os.path.join(out, "atlas.h5")]
                    seconds.setdefault(build, []).append(bench.run(cmd)[0])
                    images.setdefault(build, []).append(exr.rgb(path).mean(axis=2))
            result = bench.seed_spread(images, seconds)
            # Do the builds estimate the same image? Relative squared difference of their means, against
            # the same quantity expected from their noise alone (the sum of the means' variances).
            ma, mb = (np.mean(images[b], axis=0) for b in ("A", "B"))
            denom = (ma + mb) ** 2 / 4 + 0.01
            diff = float(np.mean((ma - mb) ** 2 / denom))
            noise = float(np.mean((np.var(images["A"], axis=0, ddof=1) + np.var(images["B"], axis=0, ddof=1))
                                  / a.seeds / denom))
            rows.append((name, mode, result["A"], result["B"], diff / noise))
            print("%s %s: relvar %.4g -> %.4g, seconds %.2f -> %.2f, efficiency x%.2f, mean difference / noise %.2f"
                  % (name, mode, result["A"][0], result["B"][0], result["A"][1], result["B"][1],
                     result["B"][2] / result["A"][2], diff / noise), flush=True)
    if not rows:
        sys.exit("bench_ab: no scene selected")
    lines = ["## A/B: %s" % a.what, "",
             "`%s`, %s, %d threads, %d spp, %d seeds per cell, builds interleaved. A = `%s`, B = this checkout. "
             "Relative variance: of one render, from the spread across the seeds of each pixel's luminance, over "
             "(mean^2 + 0.01), mean over the pixels. Seconds: median wall time of the render command. Efficiency = "
             "1 / (relative variance x seconds). Last column: the mean squared relative difference of the two "
             "builds' mean images over what their noise alone gives (about 1 when they estimate the same image)."
             % (shlex.join(["scripts/bench_ab.py"] + sys.argv[1:]), datetime.date.today().isoformat(), a.threads,
                a.spp, a.seeds, a.old_bin), "",
             "| scene | mode | A: rel. variance | seconds | B: rel. variance | seconds | efficiency B / A | mean difference / noise |",
             "|---|---|---|---|---|---|---|---|"]
    for name, mode, ra, rb, same in rows:
        lines.append("| `%s` | %s | %.4g | %.2f | %.4g | %.2f | %.2f | %.2f |"
                     % (name, mode, ra[0], ra[1], rb[0], rb[1], rb[2] / ra[2], same))
    bench.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)


if __name__ == "__main__":
    main()
