#!/usr/bin/env python3
"""Benchmark of the choices render --mode auto's pilot makes, two settings at a time at equal render time:

  --choice depth:   how many vertices to guide, the first vertex alone against every vertex (roulette below
                    throughput 0.1); gave render's kShallowMargin (tools/render/integrator.h).
  --choice connect: guiding every vertex without and with caustic connections; gave kConnectMargin.

Each (scene, setting) renders --time SECONDS with several seeds, on one atlas per scene, both with the
caustic light tracer and the flags of the scene's row, so that only the choice differs. Noise:
bench.seed_spread (variance across the seeds).

  scripts/bench_choice.py --choice depth --out out/bench/guide-depth -o docs/benchmarks/guide-depth.md
"""
import argparse
import datetime
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench  # noqa: E402
import exr  # noqa: E402

# Per choice: its two settings (label, flags), and per scene its resolution and the flags both settings share:
# the light paths per pixel and (depth) the connections that --mode auto's pilot chose there
# (docs/benchmarks/targets-connect.md; the window room: its pilot's choice).
FIRST = ["--guide-vertices", "1", "--rr-threshold", "0.3"]
EVERY = ["--guide-vertices", "0", "--rr-threshold", "0.1"]
CHOICES = {
    "depth": {
        "title": "Guiding the first vertex against every vertex",
        "settings": [("first vertex", FIRST), ("every vertex", EVERY)],
        "scenes": [
            ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256", ["--light-paths", "0.133", "--connect", "on"]),
            ("ring", "scenes/thesis/metal_ring/ring.xml", "480x270", ["--light-paths", "0.84", "--connect", "on"]),
            ("window_room", "scenes/window_room/window_room.xml", "320x240", ["--light-paths", "0.12"]),
        ],
    },
    "connect": {
        "title": "Guiding every vertex without and with caustic connections",
        "settings": [("without connections", EVERY + ["--connect", "off"]), ("with connections", EVERY + ["--connect", "on"])],
        "scenes": [
            ("bidir", "scenes/thesis/veach_bidir/bidir.xml", "384x288", ["--light-paths", "0.13"]),
            ("cbox_spiegelboxen", "scenes/thesis/cbox_spiegelboxen.xml", "256x256", ["--light-paths", "0.5"]),
            ("cbox_kugeln", "scenes/thesis/cbox_kugeln.xml", "256x256", ["--light-paths", "0.133"]),
            ("ring", "scenes/thesis/metal_ring/ring.xml", "480x270", ["--light-paths", "0.84"]),
        ],
    },
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--choice", required=True, choices=sorted(CHOICES))
    bench.add_spread_options(ap, seeds=3)
    ap.add_argument("--seconds", type=float, default=30)
    a = ap.parse_args()
    if a.seeds < 2 or not a.seconds > 0:
        sys.exit("bench_choice: needs --seeds >= 2 and --seconds > 0")
    choice = CHOICES[a.choice]
    (label_a, flags_a), (label_b, flags_b) = choice["settings"]
    rows = []
    for (name, scene, res, shared), out in bench.selected_scenes(choice["scenes"], a):
        bench.run(["make", "-s", "-f", "pipelines/guided.mk", "SCENE=" + scene, "OUT=" + out, "BIN=" + bench.BIN,
                   "RESOLUTION=" + res, "atlas"])
        images, seconds = {}, {}
        # Seeds outermost and settings interleaved, so that a busy spell of the machine hits both.
        for seed in range(1, a.seeds + 1):
            for index, (setting, flags) in enumerate(choice["settings"]):
                path = os.path.join(out, "%s-%d-%d.exr" % (a.choice, index, seed))
                cmd = [bench.BIN + "/render", scene, "-o", path, "--atlas", os.path.join(out, "atlas.h5"),
                       "--resolution", res, "--mode", "nee+bsdf+cache", "--caustics", "on", "--time", str(a.seconds),
                       "--seed", str(seed), "-t", str(a.threads), "-q", "--no-scene-warnings"] + shared + flags
                seconds.setdefault(setting, []).append(bench.run(cmd)[0])
                images.setdefault(setting, []).append(exr.rgb(path).mean(axis=2))
        r = bench.seed_spread(images, seconds)
        ra, rb = r[label_a], r[label_b]
        rows.append((name, " ".join(shared), ra, rb))
        print("%s: relvar %s %.4g, %s %.4g; efficiency %s / %s %.2f"
              % (name, label_a, ra[0], label_b, rb[0], label_b, label_a, rb[2] / ra[2]), flush=True)
    if not rows:
        sys.exit("bench_choice: no scene selected")
    lines = ["## %s, at equal time" % choice["title"], "",
             "`%s`, %s, %d threads, `render --time %g` per render, %d seeds per cell, one atlas per scene "
             "(pipelines/guided.mk's defaults), `--mode nee+bsdf+cache --caustics on` and the flags in the table; "
             "%s: `%s`, %s: `%s`. Relative variance: of one render, from the spread across the seeds of each "
             "pixel's luminance over (mean^2 + 0.01), averaged over the pixels. Efficiency = 1 / (relative "
             "variance x seconds)." % (" ".join(["scripts/bench_choice.py"] + sys.argv[1:]),
                                      datetime.date.today().isoformat(), a.threads, a.seconds, a.seeds,
                                      label_a, " ".join(flags_a), label_b, " ".join(flags_b)), "",
             "| scene | shared flags | %s: rel. variance | %s: rel. variance | efficiency %s / %s |"
             % (label_a, label_b, label_b, label_a),
             "|---|---|---|---|---|"]
    for name, shared, ra, rb in rows:
        lines.append("| `%s` | `%s` | %.4g | %.4g | %.2f |" % (name, shared, ra[0], rb[0], rb[2] / ra[2]))
    bench.write_text(a.output, "\n".join(lines) + "\n")
    print("wrote " + a.output)


if __name__ == "__main__":
    main()
