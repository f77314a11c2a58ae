#!/usr/bin/env python3
"""Equal-time A/B of render settings on one scene (issue 25: hybrid caches against photon-only caches).

  scripts/bench-hybrid.py SCENE --reference REF.exr --resolution WxH --budget S --prep P --repeats N \
      --config 'unguided=--mode nee+bsdf' --config 'photons=--atlas A --mode nee+bsdf+cache' ...

Every configuration renders N times (seeds 7, 8, ...) with --time = budget - prep (its preprocessing, P
seconds, measured by the caller, is counted inside the budget; pass 0 for configurations without it
via NAME:0=FLAGS), the configurations' order reversed on every repeat, so that the shared machine's
drift hits all alike. Per configuration the median relMSE (against REF) x total seconds is kept;
efficiency = 1 / (relMSE x total seconds), and its ratio to the first configuration's is printed as a
markdown table, also with the reference's own noise taken out of every relMSE (where REF has variance
layers: compare-images' relmse_reference_noise; that column takes statistics.median of the net relMSE x
seconds, which with an even number of repeats is the mean of the middle two, where the plain column keeps
the upper one). A configuration named NAME@old renders with the tools in --old-bin instead (another build,
e.g. a git worktree of the previous commit), so that two builds are compared in one run. Only the
Python standard library is used.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

BIN = os.environ.get("IRIS_BIN", "build/bin")


def run(cmd):
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if p.returncode != 0:
        sys.exit("bench-hybrid: failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stderr.strip()))
    return wall, p.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--reference", required=True)
    ap.add_argument("--resolution", required=True)
    ap.add_argument("--budget", type=float, required=True, help="total seconds per render, preprocessing included")
    ap.add_argument("--prep", type=float, default=0.0, help="preprocessing seconds of the guided configurations")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--old-bin", help="the tools' folder of another build, for configurations named NAME@old")
    ap.add_argument("--config", action="append", required=True,
                    help="NAME=FLAGS (guided: preprocessing counted) or NAME:0=FLAGS (no preprocessing)")
    a = ap.parse_args()
    configs = []
    for c in a.config:
        name, flags = c.split("=", 1)
        prep = a.prep
        if name.endswith(":0"):
            name, prep = name[:-2], 0.0
        configs.append((name, prep, flags.split()))
    rows = {name: [] for name, _, _ in configs}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.repeats):
            for name, prep, flags in (configs if r % 2 == 0 else configs[::-1]):
                out = os.path.join(tmp, "%s-%d.exr" % (name, r))
                bin_dir = BIN
                if name.endswith("@old"):
                    if not a.old_bin:
                        sys.exit("bench-hybrid: %s needs --old-bin" % name)
                    bin_dir = a.old_bin
                cmd = [bin_dir + "/render", a.scene, "-o", out, "--resolution", a.resolution, "--time",
                       "%.3f" % (a.budget - prep), "--seed", str(7 + r), "-q"] + flags
                wall, _ = run(cmd)
                _, meta = run([BIN + "/compare-images", out, "--metadata"])
                m = dict(line.split(" ", 1) for line in meta.splitlines() if " " in line)
                _, js = run([BIN + "/compare-images", out, a.reference, "--json"])
                c = json.loads(js)
                total = wall + prep
                # The reference's own noise (from its variance layers, where it has them) taken out.
                net = max(c["relmse"] - (c.get("relmse_reference_noise") or 0.0), 1e-12)  # (null without layers)
                rows[name].append(dict(relmse=c["relmse"], total=total, spp=int(m["iris:spp"]),
                                       cost=c["relmse"] * total, net_cost=net * total,
                                       hybrid=m.get("iris:hybrid_caches", "")))
                print("%-12s seed %d: relMSE %.4g, %d spp, %.2f s total" % (name, 7 + r, c["relmse"],
                      int(m["iris:spp"]), total), file=sys.stderr)
    base = base_net = None
    print("| setting | flags | relMSE (median; all) | spp | total s | efficiency | vs %s | same, ref. noise removed |"
          % configs[0][0])
    print("|---|---|---|---|---|---|---|---|")
    for name, prep, flags in configs:
        xs = sorted(rows[name], key=lambda x: x["cost"])
        med = xs[len(xs) // 2]
        eff = 1.0 / med["cost"]
        eff_net = 1.0 / statistics.median(x["net_cost"] for x in rows[name])
        if base is None:
            base, base_net = eff, eff_net
        print("| %s | `%s` | %.4g (%s) | %d | %.1f | %.3g | **%.2f** | %.2f |" % (
            name, " ".join(flags), med["relmse"], " / ".join("%.4g" % x["relmse"] for x in rows[name]), med["spp"],
            med["total"], eff, eff / base, eff_net / base_net))


if __name__ == "__main__":
    main()
