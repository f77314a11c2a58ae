#!/usr/bin/env python3
"""Equal-time guided renders through pipelines/guided.mk with two builds of the tools, interleaved.

  scripts/bench-reach.py SCENE --ref REF.exr --bins A_DIR,B_DIR --names A,B --budget 60 --repeats 3 --out DIR

For every repeat r (SEED = r + --first-seed) and every tool directory (order alternated between repeats, so the
shared machine's drift hits both alike): `make atlas` with BIN = that directory, then the guided render
(`make guided`) with TIME = budget - the measured preprocessing, so each costs the budget in all; relMSE
against REF (compare-images), spp, preprocessing seconds and the usable caches (inspect-caches) are
printed per run, then the medians. Standard library only.
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys


def sh(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("bench-reach: failed (%d): %s\n%s%s" % (p.returncode, " ".join(cmd), p.stdout, p.stderr))
    return p.stdout + p.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--ref", required=True)
    ap.add_argument("--bins", required=True)
    ap.add_argument("--names", required=True)
    ap.add_argument("--budget", type=float, default=60)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--first-seed", type=int, default=1, help="SEED of the first repeat")
    ap.add_argument("--out", required=True)
    ap.add_argument("vars", nargs="*", help="further guided.mk variables, VAR=VALUE")
    a = ap.parse_intermixed_args()
    bins, names = a.bins.split(","), a.names.split(",")
    rows = {n: [] for n in names}
    cmp_bin = bins[0] + "/compare-images"
    for r in range(a.repeats):
        order = list(zip(bins, names))
        if r % 2 == 1:
            order.reverse()
        for b, n in order:
            out = os.path.join(a.out, "%s-r%d" % (n, r))
            base = ["make", "--no-print-directory", "-f", "pipelines/guided.mk", "BIN=" + b, "SCENE=" + a.scene,
                    "OUT=" + out, "SEED=%d" % (r + a.first_seed)] + a.vars
            sh(base + ["atlas"])
            prep = sum(float(open(os.path.join(out, s + ".seconds")).read()) for s in ("photons", "caches", "atlas"))
            sh(base + ["TIME=%.3f" % max(a.budget - prep, 1.0), "guided"])
            img = os.path.join(out, "guided.exr")
            js = json.loads(sh([cmp_bin, img, a.ref, "--json"]))
            meta = dict(l.split(" ", 1) for l in sh([cmp_bin, img, "--metadata"]).splitlines() if " " in l)
            atlas = sh([b + "/inspect-caches", os.path.join(out, "atlas.h5")])
            m = re.search(r"^usable\s+(\d+)", atlas, re.M)
            usable = int(m.group(1)) if m else -1
            x = dict(rel=js["relmse"], trim=js["relmse_trimmed"], spp=int(meta["iris:spp"]), prep=prep,
                     usable=usable, auto=meta.get("iris:auto_guide", ""))
            rows[n].append(x)
            print("%s repeat %d: prep %.2f s, relMSE %.4g (trimmed %.4g), %d spp, %d usable caches; auto: %s" % (
                n, r, prep, x["rel"], x["trim"], x["spp"], usable, x["auto"]), flush=True)
    print("\n| setting | relMSE median (per repeat) | trimmed relMSE median | spp | usable caches | preprocessing s |")
    print("|---|---|---|---|---|---|")
    for n in names:
        xs = rows[n]
        med = lambda k: statistics.median(x[k] for x in xs)
        print("| %s | %.4g (%s) | %.4g | %d | %d | %.2f |" % (
            n, med("rel"), " / ".join("%.4g" % x["rel"] for x in xs), med("trim"), med("spp"), med("usable"),
            med("prep")))


if __name__ == "__main__":
    main()
