#!/usr/bin/env python3
"""Benchmark of how many vertices to guide: the first vertex alone against every vertex (roulette below
throughput 0.1), at equal render time, the two settings render --mode auto's pilot chooses between.

Each (scene, setting) renders --time SECONDS with several seeds, on one atlas per scene, both with the
caustic light tracer (and caustic connections where the scene's auto render takes them), so that only the
guided vertices differ. Noise: bench.seed_spread (variance across the seeds). This measurement gave
render's kShallowMargin (tools/render/integrator.h).

  scripts/bench_guide_depth.py --out out/bench/guide-depth -o docs/benchmarks/guide-depth.md
"""
import argparse
import datetime
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench  # noqa: E402
import exr  # noqa: E402

# Scene, resolution, and the flags both settings share: the light paths per pixel and connections that
# --mode auto's pilot chose there (docs/benchmarks/targets-connect.md; the window room: its pilot's choice).
SCENES = [
    ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256", ["--light-paths", "0.133", "--connect", "on"]),
    ("ring", "scenes/thesis/metal_ring/ring.xml", "480x270", ["--light-paths", "0.84", "--connect", "on"]),
    ("window_room", "scenes/window_room/window_room.xml", "320x240", ["--light-paths", "0.12"]),
]
SETTINGS = [
    ("first vertex", ["--guide-vertices", "1", "--rr-threshold", "0.3"]),
    ("every vertex", ["--guide-vertices", "0", "--rr-threshold", "0.1"]),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, help="folder for the renders")
    ap.add_argument("-o", "--output", required=True, help="report (Markdown)")
    ap.add_argument("--seconds", type=float, default=30)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--only", default="", help="comma-separated scene names")
    a = ap.parse_args()
    if a.seeds < 2 or not a.seconds > 0:
        sys.exit("bench_guide_depth: needs --seeds >= 2 and --seconds > 0")
    only = set(filter(None, a.only.split(",")))
    rows = []
    for name, scene, res, shared in SCENES:
        if only and name not in only:
            continue
        out = os.path.join(a.out, name)
        os.makedirs(out, exist_ok=True)
        bench.run(["make", "-s", "-f", "pipelines/guided.mk", "SCENE=" + scene, "OUT=" + out, "BIN=" + bench.BIN,
                   "RESOLUTION=" + res, "atlas"])
        images, seconds = {}, {}
        # Seeds outermost and settings interleaved, so that a busy spell of the machine hits both.
        for seed in range(1, a.seeds + 1):
            for setting, flags in SETTINGS:
                path = os.path.join(out, "%s-%d.exr" % (setting.split()[0], seed))
                cmd = [bench.BIN + "/render", scene, "-o", path, "--atlas", os.path.join(out, "atlas.h5"),
                       "--resolution", res, "--mode", "nee+bsdf+cache", "--caustics", "on", "--time", str(a.seconds),
                       "--seed", str(seed), "-t", str(a.threads), "-q", "--no-scene-warnings"] + shared + flags
                seconds.setdefault(setting, []).append(bench.run(cmd)[0])
                images.setdefault(setting, []).append(exr.rgb(path).mean(axis=2))
        r = bench.seed_spread(images, seconds)
        first, every = r["first vertex"], r["every vertex"]
        rows.append((name, " ".join(shared), first, every))
        print("%s: relvar first %.4g, every %.4g; efficiency every / first %.2f"
              % (name, first[0], every[0], every[2] / first[2]), flush=True)
    if not rows:
        sys.exit("bench_guide_depth: no scene selected")
    lines = ["## Guiding the first vertex against every vertex, at equal time", "",
             "`%s`, %s, %d threads, `render --time %g` per render, %d seeds per cell, one atlas per scene "
             "(pipelines/guided.mk's defaults), `--mode nee+bsdf+cache --caustics on` and the flags in the table; "
             "first vertex: `--guide-vertices 1 --rr-threshold 0.3`, every vertex: `--guide-vertices 0 "
             "--rr-threshold 0.1`. Relative variance: of one render, from the spread across the seeds of each "
             "pixel's luminance over (mean^2 + 0.01), averaged over the pixels. Efficiency = 1 / (relative "
             "variance x seconds)." % (" ".join(["scripts/bench_guide_depth.py"] + sys.argv[1:]),
                                      datetime.date.today().isoformat(), a.threads, a.seconds, a.seeds), "",
             "| scene | shared flags | first vertex: rel. variance | every vertex: rel. variance | efficiency every / first |",
             "|---|---|---|---|---|"]
    for name, shared, first, every in rows:
        lines.append("| `%s` | `%s` | %.4g | %.4g | %.2f |" % (name, shared, first[0], every[0], every[2] / first[2]))
    tmp = a.output + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, a.output)
    print("wrote " + a.output)


if __name__ == "__main__":
    main()
