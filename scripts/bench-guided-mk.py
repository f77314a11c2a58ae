#!/usr/bin/env python3
"""Equal-time guided vs unguided through pipelines/guided.mk at several total budgets, repeated.

  scripts/bench-guided-mk.py SCENE --ref-dir DIR --ref-spp N --budgets 30,60,120 --repeats 2 --out DIR [VAR=VALUE ...]

For every repeat r (SEED = r + 1) and budget B (seconds, preprocessing included): `make photons caches
atlas` (timed by guided.mk), then TIME = B - preprocessing, so that the guided render (TIME) and the
unguided one (TIME + preprocessing) both cost B in all; the two renders run one after the other, the
unguided first on odd repeats (the shared machine's drift hits both alike), then `make compare` against
the reference guided.mk finds in DIR (REF_DIR, REF_SPP; render it first, e.g. `make ... reference`).
Prints one line per run and a markdown table of the medians per budget; ratio = relMSE unguided /
relMSE guided = the efficiency ratio at equal time (> 1: guiding wins). Standard library only.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

BIN = os.environ.get("IRIS_BIN", "build/bin")


def sh(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("bench-guided-mk: failed (%d): %s\n%s%s" % (p.returncode, " ".join(cmd), p.stdout, p.stderr))
    return p.stdout


def metrics(image, ref):
    meta = dict(l.split(" ", 1) for l in sh([BIN + "/compare-images", image, "--metadata"]).splitlines() if " " in l)
    js = json.loads(sh([BIN + "/compare-images", image, ref, "--json"]))
    return js["relmse"], js["relmse_trimmed"], int(meta["iris:spp"]), meta.get("iris:auto_guide", "")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--ref-dir", required=True)
    ap.add_argument("--ref-spp", required=True)
    ap.add_argument("--budgets", default="30,60,120")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--out", required=True)
    ap.add_argument("vars", nargs="*", help="further guided.mk variables, VAR=VALUE")
    a = ap.parse_intermixed_args()
    name = os.path.splitext(os.path.basename(a.scene))[0]
    ref = os.path.join(a.ref_dir, "%s-%sspp.exr" % (name, a.ref_spp))
    if not os.path.exists(ref):
        sys.exit("bench-guided-mk: no reference " + ref)
    budgets = [float(b) for b in a.budgets.split(",")]
    rows = {b: [] for b in budgets}
    for r in range(a.repeats):
        for b in budgets:
            out = os.path.join(a.out, "b%g-r%d" % (b, r))
            base = ["make", "--no-print-directory", "-f", "pipelines/guided.mk", "BIN=" + BIN, "SCENE=" + a.scene,
                    "OUT=" + out, "REF_DIR=" + a.ref_dir, "REF_SPP=" + a.ref_spp, "SEED=%d" % (r + 1)] + a.vars
            sh(base + ["atlas"])
            prep = sum(float(open(os.path.join(out, s + ".seconds")).read()) for s in ("photons", "caches", "atlas"))
            mk = base + ["TIME=%.3f" % max(b - prep, 1.0)]
            for target in (["guided", "unguided"] if r % 2 == 0 else ["unguided", "guided"]):
                sh(mk + [target])
            sh(mk + ["compare"])
            g, gt, gspp, auto = metrics(os.path.join(out, "guided.exr"), ref)
            u, ut, uspp, _ = metrics(os.path.join(out, "unguided.exr"), ref)
            rows[b].append(dict(g=g, u=u, gt=gt, ut=ut, gspp=gspp, uspp=uspp, prep=prep, auto=auto))
            print("budget %g s, repeat %d: prep %.2f s; guided relMSE %.4g (trimmed %.4g, %d spp), unguided %.4g "
                  "(trimmed %.4g, %d spp), ratio %.2f (trimmed %.2f); auto: %s" % (
                      b, r, prep, g, gt, gspp, u, ut, uspp, u / g, ut / gt, auto), flush=True)
    print("\n| total s | preprocessing s | guided relMSE (median; all) | spp | unguided relMSE (median; all) | spp "
          "| ratio unguided/guided (median; all) | trimmed relMSE ratio (median) |")
    print("|---|---|---|---|---|---|---|---|")
    for b in budgets:
        xs = rows[b]
        med = lambda k: statistics.median(x[k] for x in xs)
        ratios = [x["u"] / x["g"] for x in xs]
        print("| %g | %.2f | %.4g (%s) | %d | %.4g (%s) | %d | **%.2f** (%s) | %.2f |" % (
            b, med("prep"), med("g"), " / ".join("%.4g" % x["g"] for x in xs), med("gspp"),
            med("u"), " / ".join("%.4g" % x["u"] for x in xs), med("uspp"),
            statistics.median(ratios), " / ".join("%.2f" % q for q in ratios),
            statistics.median(x["ut"] / x["gt"] for x in xs)))


if __name__ == "__main__":
    main()
