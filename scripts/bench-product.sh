#!/usr/bin/env bash
# Issue 25, part 2: product sampling with glossy lobes (render --product on) against the map alone, on the
# glass-spheres box with a rough aluminium floor and a rough copper back wall (scenes/cbox/glossy_spheres.xml),
# at equal total time, guiding every vertex and guiding the first vertex. Writes docs/benchmarks/product.md
# (run from the repository root on an otherwise idle machine, ~25 min with its references):
#
#   make -f pipelines/bench.mk product          (or: bash scripts/bench-product.sh)
#
# Two references, each checked against the other: an unguided one (2048 spp) and a guided one (240 s,
# every vertex, the map alone); the table is measured against the guided one, and also gives each ratio
# with the reference's noise removed.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/bin}
source scripts/bench-lib.sh
bin=$BIN
PYTHON=${PYTHON:-/usr/bin/python3}
OUT=${OUT:-out/bench/product}
REF_DIR=${REF_DIR:-.cache/references}
REPORT=${REPORT:-docs/benchmarks/product.md}
SCENE=scenes/cbox/glossy_spheres.xml
RES=256x256
mkdir -p "$OUT" "$REF_DIR"

make -s -f pipelines/guided.mk BIN="$BIN" SCENE=$SCENE OUT="$OUT" RESOLUTION=$RES atlas >&2
prep=$(cat "$OUT"/{photons,caches,atlas}.seconds | awk '{s += $1} END {printf "%.2f", s}')
every="--atlas $OUT/atlas.h5 --mode nee+bsdf+cache --guide-vertices 0 --rr-threshold 0.1"
first="--atlas $OUT/atlas.h5 --mode nee+bsdf+cache"
table() {  # budget repeats
  IRIS_BIN=$BIN $PYTHON scripts/bench-hybrid.py $SCENE --reference "$ref_guided" --resolution $RES --budget "$1" \
    --prep "$prep" --repeats "$2" --config "unguided:0=--mode nee+bsdf" \
    --config "every=$every --product off" --config "every+product=$every --product on" \
    --config "first=$first --product off" --config "first+product=$first --product on"
}

ref_unguided=$REF_DIR/glossy_spheres-$RES-unguided-2048spp.exr
ref_guided=$REF_DIR/glossy_spheres-$RES-every-240s.exr
[[ -f $ref_unguided ]] || "$BIN/render" $SCENE -o "$ref_unguided" --resolution $RES --spp 2048 --seed 1000003 --variance --sampler independent -q \
  --no-scene-warnings
[[ -f $ref_guided ]] || "$BIN/render" $SCENE -o "$ref_guided" --resolution $RES --time 240 --seed 2000003 --variance --sampler independent -q \
  $every --product off --no-scene-warnings

{
  echo "# Product sampling with glossy lobes (issue 25, part 2)"
  echo
  echo "\`bash scripts/bench-product.sh\` (\`make -f pipelines/bench.mk product\`), $(date -u +%Y-%m-%d), $(nproc) threads,"
  echo "load before the run $(cut -d' ' -f1 /proc/loadavg). \`$SCENE\` at $RES (the glass-spheres box with a rough"
  echo "aluminium floor, GGX alpha 0.3, and a rough copper back wall, alpha 0.2: both one glossy lobe, which the"
  echo "caches guide). The map alone against its product with the lobe (\`--product on\`), guiding every vertex"
  echo "(\`--guide-vertices 0 --rr-threshold 0.1\`) and the first vertex, beside the unguided tracer; interleaved,"
  echo "seeds 7 on, per setting the median by relMSE x total seconds; guided totals"
  echo "include the preprocessing (pipelines/guided.mk defaults: $prep s). Efficiency = 1 / (relMSE x total"
  echo "seconds); relMSE x spp is the noise per sample, spp at equal time the cost."
  echo
  reference_paragraph "$ref_guided" "Guided (every vertex, the map alone), 240 s, seed 2000003" "$ref_unguided" \
    "unguided, 2048 spp, seed 1000003" "The tables use the guided reference."
  echo
  echo "## 30 s total (3 repeats)"
  echo
  table 30 3
  echo
  echo "## 60 s total (2 repeats)"
  echo
  table 60 2
} > "$REPORT.tmp"
mv "$REPORT.tmp" "$REPORT"
echo "bench-product: wrote $REPORT" >&2
