#!/usr/bin/env python3
"""Benchmark of render's pixel sampler: --sampler sobol (stratified pixel position and first bounce)
against --sampler independent, unguided and guided, at a fixed number of samples per pixel.

Each (scene, mode, sampler) is rendered with several seeds; its noise is the variance across the seeds
of each pixel (luminance), relative to (mean^2 + 0.01) with the mean over every render of the scene (all
modes and samplers estimate the same image), averaged over the pixels: the relative variance of one
render. The sample variance inside one render cannot measure it: stratified samples are not independent.
Efficiency = 1 / (relative variance x seconds), seconds = the median wall time of the render command.

  scripts/bench_sampler.py --out out/bench/sampler -o docs/benchmarks/sampler.md
"""
import argparse
import datetime
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench  # noqa: E402
import exr  # noqa: E402

# Scene, resolution (half the film), and the modes measured. The guided settings are what render
# --mode auto chose on these scenes in docs/benchmarks/targets-connect.md, fixed here so that every seed
# renders the same estimator.
SCENES = [
    ("ring", "scenes/thesis/metal_ring/ring.xml", "480x270", [
        ("nee+bsdf", []),
        ("guided", ["--mode", "nee+bsdf+cache", "--caustics", "on", "--light-paths", "0.8"]),
    ]),
    ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256", [
        ("nee+bsdf", []),
        ("guided", ["--mode", "nee+bsdf+cache", "--guide-vertices", "0", "--rr-threshold", "0.1", "--caustics", "on",
                    "--light-paths", "0.15", "--connect", "on"]),
    ]),
    ("cbox_nur_box", "scenes/thesis/cbox_nur_box.xml", "256x256", [
        ("nee+bsdf", []),
    ]),
]
SAMPLERS = ("independent", "sobol")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    bench.add_spread_options(ap, seeds=6)
    ap.add_argument("--spp", type=int, default=64)
    a = ap.parse_args()
    if a.seeds < 2 or a.spp < 1:
        sys.exit("bench_sampler: needs --seeds >= 2 and --spp >= 1")
    rows = []
    for (name, scene, res, modes), out in bench.selected_scenes(SCENES, a):
        if any(m != "nee+bsdf" for m, _ in modes):
            bench.run(["make", "-s", "-f", "pipelines/guided.mk", "SCENE=" + scene, "OUT=" + out, "BIN=" + bench.BIN,
                       "atlas"])
        images, seconds = {}, {}
        # Seeds outermost and samplers interleaved, so that a busy spell of the machine hits both.
        for seed in range(1, a.seeds + 1):
            for mode, extra in modes:
                for sampler in SAMPLERS:
                    path = os.path.join(out, "%s-%s-%d.exr" % (mode.replace("+", "_"), sampler, seed))
                    cmd = [bench.BIN + "/render", scene, "-o", path, "--spp", str(a.spp), "--resolution", res, "--seed",
                           str(seed), "-t", str(a.threads), "-q", "--no-scene-warnings", "--sampler", sampler] + extra
                    if mode != "nee+bsdf":
                        cmd += ["--atlas", os.path.join(out, "atlas.h5")]
                    seconds.setdefault((mode, sampler), []).append(bench.run(cmd)[0])
                    images.setdefault((mode, sampler), []).append(exr.rgb(path).mean(axis=2))
        result = bench.seed_spread(images, seconds)
        for mode, _ in modes:
            ind, sob = result[(mode, "independent")], result[(mode, "sobol")]
            rows.append((name, mode, ind, sob))
            print("%s %s: relvar %.4g -> %.4g, seconds %.2f -> %.2f, efficiency x%.2f"
                  % (name, mode, ind[0], sob[0], ind[1], sob[1], sob[2] / ind[2]), flush=True)
    if not rows:
        sys.exit("bench_sampler: no scene selected")
    lines = ["## Pixel sampler: stratified (sobol) against independent", "",
             "`%s`, %s, %d threads, %d spp, %d seeds per cell. Relative variance: of one render, from the spread "
             "across the seeds of each pixel's luminance, over (mean^2 + 0.01), mean over the pixels (the mean image: "
             "every render of the scene). Seconds: median wall time of the render command. Efficiency = 1 / (relative "
             "variance x seconds)." % (" ".join(["scripts/bench_sampler.py"] + sys.argv[1:]),
                                         datetime.date.today().isoformat(), a.threads, a.spp, a.seeds), "",
             "| scene | mode | independent: rel. variance | seconds | sobol: rel. variance | seconds | efficiency sobol / independent |",
             "|---|---|---|---|---|---|---|"]
    for name, mode, ind, sob in rows:
        lines.append("| `%s` | %s | %.4g | %.2f | %.4g | %.2f | %.2f |" % (name, mode, ind[0], ind[1], sob[0], sob[1],
                                                                        sob[2] / ind[2]))
    # Scenes measured in both modes: rows (name, "nee+bsdf", ...) then (name, "guided", ...).
    pairs = [(u, g) for u, g in zip(rows, rows[1:]) if u[0] == g[0]]
    if pairs:
        lines += ["", "Efficiency of the guided mode over nee+bsdf, with each sampler:", "",
                  "| scene | independent | sobol |", "|---|---|---|"]
        for u, g in pairs:
            lines.append("| `%s` | %.2f | %.2f |" % (u[0], g[2][2] / u[2][2], g[3][2] / u[3][2]))
    bench.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)


if __name__ == "__main__":
    main()
