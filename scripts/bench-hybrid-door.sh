#!/usr/bin/env bash
# Issue 25, part 1: hybrid caches (render --learn) against photon-only caches and the unguided tracer on
# the room lit through a door (scenes/door/door.xml), at equal total time, every vertex guided. Writes
# docs/benchmarks/hybrid-door.md (run from the repository root on an otherwise idle machine, ~25 min):
#
#   make -f pipelines/bench.mk hybrid          (or: bash scripts/bench-hybrid-door.sh)
#
# Two photon budgets: 25k photon paths (photons reach the near room badly: at equal time their caches
# gain nothing over unguided sampling) and the pipeline's default 250k. Two references, each
# checked against the other: an unguided one (2048 spp) and a hybrid one (300 s; 12x less noise for the
# time); the tables are measured against the hybrid one, and also give each ratio with the reference's
# noise removed.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/bin}
source scripts/bench-lib.sh
bin=$BIN
PYTHON=${PYTHON:-/usr/bin/python3}
OUT=${OUT:-out/bench/hybrid-door}
REF_DIR=${REF_DIR:-.cache/references}
REPORT=${REPORT:-docs/benchmarks/hybrid-door.md}
SCENE=scenes/door/door.xml
RES=240x160
mkdir -p "$OUT" "$REF_DIR"

# The two atlases through the pipeline (MIN_CAUSTIC=0: the door has no specular surface, so the default
# pipeline would place no caches at all and render unguided).
prep=()
for paths in 25000 250000; do
  make -s -f pipelines/guided.mk BIN="$BIN" SCENE=$SCENE OUT="$OUT/p$paths" PATHS=$paths MIN_CAUSTIC=0 \
    RESOLUTION=$RES atlas >&2
  prep+=("$(cat "$OUT/p$paths"/{photons,caches,atlas}.seconds | awk '{s += $1} END {printf "%.2f", s}')")
done
guided() { echo "--atlas $OUT/p$1/atlas.h5 --mode nee+bsdf+cache --guide-vertices 0 --rr-threshold 0.1"; }

ref_unguided=$REF_DIR/door-$RES-unguided-2048spp.exr
ref_hybrid=$REF_DIR/door-$RES-hybrid-300s.exr
[[ -f $ref_unguided ]] || "$BIN/render" $SCENE -o "$ref_unguided" --resolution $RES --spp 2048 --seed 1000003 --variance --sampler independent -q
[[ -f $ref_hybrid ]] || "$BIN/render" $SCENE -o "$ref_hybrid" --resolution $RES --time 300 --seed 2000003 --variance --sampler independent \
  -q $(guided 25000) --learn

table() {  # budget repeats paths
  IRIS_BIN=$BIN $PYTHON scripts/bench-hybrid.py $SCENE --reference "$ref_hybrid" --resolution $RES --budget "$1" \
    --prep "$4" --repeats "$2" --config "unguided:0=--mode nee+bsdf" --config "photons=$(guided "$3")" \
    --config "hybrid=$(guided "$3") --learn"
}
{
  echo "# Hybrid caches on the room lit through a door (issue 25, part 1)"
  echo
  echo "\`bash scripts/bench-hybrid-door.sh\` (\`make -f pipelines/bench.mk hybrid\`), $(date -u +%Y-%m-%d), $(nproc) threads,"
  echo "load before the run $(cut -d' ' -f1 /proc/loadavg). \`scenes/door/door.xml\` at $RES; every vertex guided (\`--guide-vertices 0"
  echo "--rr-threshold 0.1\`), photon-only caches (\`--mode nee+bsdf+cache\`) against the same atlas with \`--learn\`"
  echo "(hybrid) and the unguided tracer (\`--mode nee+bsdf\`), interleaved, seeds 7 on, per setting the median by"
  echo "relMSE x total seconds; guided totals include the preprocessing (trace-photons + place-caches +"
  echo "fill-caches through pipelines/guided.mk with MIN_CAUSTIC=0: ${prep[0]} s with 25k photon paths, ${prep[1]} s"
  echo "with 250k). Efficiency = 1 / (relMSE x total seconds)."
  echo
  reference_paragraph "$ref_hybrid" "Hybrid, 300 s, seed 2000003" "$ref_unguided" "unguided, 2048 spp, seed 1000003" \
    "The tables use the hybrid reference."
  echo
  echo "## 25k photon paths, 30 s total (3 repeats)"
  echo
  table 30 3 25000 "${prep[0]}"
  echo
  echo "## 25k photon paths, 60 s total (2 repeats)"
  echo
  table 60 2 25000 "${prep[0]}"
  echo
  echo "## 250k photon paths (the pipeline's default), 30 s total (3 repeats)"
  echo
  table 30 3 250000 "${prep[1]}"
} > "$REPORT.tmp"
mv "$REPORT.tmp" "$REPORT"
echo "bench-hybrid-door: wrote $REPORT" >&2
