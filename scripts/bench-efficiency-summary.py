#!/usr/bin/env python3
# scripts/bench-efficiency-summary.py out/eff-NAME.tsv...: summarises scripts/bench-efficiency.sh's lines: per (scene, binary, budget): median over repeats of each mode's efficiency
# 1/(relMSE x total), the median renders' figures, and the ratio auto / nee+bsdf (of the medians, and the
# median of the per-repeat ratios). Also the reference-noise-removed ratio using compare-images' estimate.
import sys, statistics, collections, subprocess, json
# Arguments: TSV files, and NAME=NOISE settings: the reference's own expected relMSE (compare-images'
# relmse_reference_noise) for that name, subtracted in the last column.
rows = []
noise = dict(a.split("=") for a in sys.argv[1:] if "=" in a)
for f in [a for a in sys.argv[1:] if "=" not in a]:
    for line in open(f):
        n, b, m, B, r, total, spp, secs, rel, load = line.split()
        rows.append(dict(name=n, bin=b, mode=m, budget=float(B), rep=int(r), total=float(total), spp=int(spp),
                         secs=float(secs), rel=float(rel), load=float(load)))
cells = collections.defaultdict(list)
for x in rows:
    x["eff"] = 1 / (x["rel"] * x["total"])
    cells[(x["name"], x["bin"], x["budget"], x["mode"])].append(x)
keys = sorted({(n, b, B) for (n, b, B, m) in cells})
print("| scene | binary | budget s | mode | total s | spp | relMSE | efficiency (repeats 1, 2, 3) | guided / unguided (per repeat) | same, reference noise removed |")
print("|---|---|---:|---|---:|---:|---:|---:|---:|---:|")
for (n, b, B) in keys:
    u = cells.get((n, b, B, "nee+bsdf"), []); g = cells.get((n, b, B, "auto"), [])
    pr = []
    for r in sorted({x["rep"] for x in u} & {x["rep"] for x in g}):
        eu = [x["eff"] for x in u if x["rep"] == r][0]; eg = [x["eff"] for x in g if x["rep"] == r][0]
        pr.append(eg / eu)
    for m, xs in (("nee+bsdf", u), ("auto", g)):
        if not xs: continue
        med = lambda k: statistics.median(x[k] for x in xs)
        ratio = clean = ""
        if m == "auto" and u:
            ratio = "**%.2fx** (%s)" % (statistics.median(x["eff"] for x in g) / statistics.median(x["eff"] for x in u),
                                        " / ".join("%.2f" % p for p in pr))
            if n in noise:
                z = float(noise[n])
                ce = lambda xs: statistics.median(1 / ((x["rel"] - z) * x["total"]) for x in xs)
                clean = "%.2fx" % (ce(g) / ce(u))
        print("| %s | %s | %g | %s | %.1f | %d | %.4g | %.4g (%s) | %s | %s |" % (n, b, B, m, med("total"), med("spp"), med("rel"),
              med("eff"), ", ".join("%.3g" % x["eff"] for x in sorted(xs, key=lambda x: x["rep"])), ratio, clean))
print()
print("loads (1-min average at each render's end): %s" % ", ".join("%.1f" % x["load"] for x in rows))
