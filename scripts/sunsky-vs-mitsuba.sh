#!/usr/bin/env bash
# iris's sky, sun and sunsky emitters against Mitsuba 0.5's: renders each scene of
# tests/data/sunsky_mitsuba/ (a diffuse plane or wall lit by daylight, or the sky seen directly; 64 x 48,
# box filter) with Mitsuba's `path` and with iris, and prints the per-channel means and iris/Mitsuba - 1.
#   scripts/sunsky-vs-mitsuba.sh MITSUBA_DIST [BUILD_DIR]
# MITSUBA_DIST holds a Mitsuba 0.5 build (its `mitsuba` binary, libraries and plugins/, with the
# `lanczos` filter that its envmap plugin needs). The scenes write PFM from Mitsuba (hdrfilm's fileFormat,
# which iris ignores with a warning) and EXR from iris; Debian's /usr/bin/python3 reads both.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: $0 MITSUBA_DIST [BUILD_DIR]" >&2; exit 1; }
dist=$(cd "$1" && pwd)
root=$(cd "$(dirname "$0")/.." && pwd)
build=${2:-$root/build}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for scene in "$root"/tests/data/sunsky_mitsuba/*.xml; do
  name=$(basename "$scene" .xml)
  LD_LIBRARY_PATH="$dist" "$dist/mitsuba" -q -o "$out/$name.pfm" "$scene" >/dev/null
  "$build/bin/render" "$scene" -o "$out/$name.exr" -q --seed 1 --no-scene-warnings
done
cd "$root/scripts"
/usr/bin/python3 - "$out" <<'PY'
import glob, os, sys
import numpy as np
import exr

def pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(h, w, 3 if kind == b"PF" else 1)

print("%-12s %-30s %-30s %s" % ("scene", "iris mean (R, G, B)", "Mitsuba mean", "iris/Mitsuba - 1"))
for p in sorted(glob.glob(os.path.join(sys.argv[1], "*.pfm"))):
    name = os.path.basename(p)[:-4]
    m = pfm(p).reshape(-1, 3).astype(np.float64).mean(0)
    a = exr.rgb(p[:-4] + ".exr").reshape(-1, 3).astype(np.float64).mean(0)
    fmt = lambda v: "(%.5g, %.5g, %.5g)" % tuple(v)
    print("%-12s %-30s %-30s %s" % (name, fmt(a), fmt(m), "(%+.2f%%, %+.2f%%, %+.2f%%)" % tuple(100 * (a / m - 1))))
PY
