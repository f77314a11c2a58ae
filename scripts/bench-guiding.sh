#!/usr/bin/env bash
# First measurement of the guided pipeline (issue 3): per scene, the preprocessing time of each stage
# (250k photon paths, 20k caches, 2k photons per cache, 16x16 maps), the atlas's memory, the per-sample
# cost of guided against unguided rendering (both at the same spp, side by side, median of 3), and the
# relMSE of guided and unguided renders at equal total time against an unguided reference.
# Usage: scripts/bench-guiding.sh [TIME] [REF_SPP]   (defaults 60 s and 1024 spp)
# Writes docs/benchmarks/guiding.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench-lib.sh
time_budget=${1:-60}
ref_spp=${2:-1024}
report=docs/benchmarks/guiding.md
mkdir -p docs/benchmarks
scenes=(cbox_kugeln.xml veach_bidir/bidir.xml)
{
  echo "## Guided pipeline: first measurement"
  echo
  echo "\`scripts/bench-guiding.sh $time_budget $ref_spp\`, $(date -u +%Y-%m-%d), $(nproc) threads. Parameters: 250k photon paths,"
  echo "20k caches (camera stride 8), k = 2000, 16x16 equal-area maps, Gaussian sigma 0.75 texel, floor 0.1, mode"
  echo "nee+bsdf+cache with BSDF fraction 0.25. Per-sample cost: both renders at 16 spp, median of 3 runs each,"
  echo "interleaved. Equal time: guided gets $time_budget s of rendering, unguided $time_budget s plus the preprocessing time."
  echo "relMSE against an unguided reference of $ref_spp spp (its own noise is included in both figures)."
  echo
  echo "| scene | photons (s) | caches (s) | atlas (s) | preprocessing (s) | atlas maps (MB) | atlas file (MB) | s/spp unguided | s/spp guided | cost ratio | relMSE unguided | relMSE guided | unguided/guided |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$report"
for s in "${scenes[@]}"; do
  name=$(basename "$s" .xml)
  out=out/bench-guiding/$name
  # The parameters of that first measurement, pinned (the pipeline's defaults have moved on since).
  make -s -f pipelines/guided.mk SCENE="$seeds/$s" OUT="$out" TIME="$time_budget" REF_SPP="$ref_spp" \
    PATHS=250000 COUNT=20000 K=2000 RES=16 MIN_CAUSTIC=0 MODE=nee+bsdf+cache BSDF_FRACTION=0.25 compare >/dev/null 2>&1
  pt=$(cat "$out/photons.seconds"); ct=$(cat "$out/caches.seconds"); at=$(cat "$out/atlas.seconds")
  prep=$(awk -v a="$pt" -v b="$ct" -v c="$at" 'BEGIN{printf "%.2f", a+b+c}')
  maps=$(awk -v n=20000 'BEGIN{printf "%.1f", n*256*4*2/1e6}')
  file=$(awk -v b="$(stat -c %s "$out/atlas.h5")" 'BEGIN{printf "%.1f", b/1e6}')
  ug=(); gd=()
  for i in 1 2 3; do
    ug+=("$("$bin/render" "$seeds/$s" -o "$out/cost.exr" --spp 16 --seed $i 2>&1 | sed -n 's/.* spp, \([0-9.]*\) s,.*/\1/p')")
    gd+=("$("$bin/render" "$seeds/$s" --atlas "$out/atlas.h5" -o "$out/cost.exr" --spp 16 --seed $i 2>&1 | sed -n 's/.* spp, \([0-9.]*\) s,.*/\1/p')")
  done
  u=$(printf '%s\n' "${ug[@]}" | median); g=$(printf '%s\n' "${gd[@]}" | median)
  ratio=$(awk -v a="$g" -v b="$u" 'BEGIN{printf "%.2f", a/b}')
  ru=$(sed -n '/== unguided/,$p' "$out/comparison.txt" | sed -n 's/^relMSE  *\([0-9.e+-]*\)$/\1/p' | head -1)
  rg=$(sed -n '/== guided/,/== unguided/p' "$out/comparison.txt" | sed -n 's/^relMSE  *\([0-9.e+-]*\)$/\1/p' | head -1)
  win=$(awk -v a="$ru" -v b="$rg" 'BEGIN{printf "%.2f", a/b}')
  line="| \`$s\` | $pt | $ct | $at | $prep | $maps | $file | $(awk -v x="$u" 'BEGIN{printf "%.3f", x/16}') | $(awk -v x="$g" 'BEGIN{printf "%.3f", x/16}') | $ratio | $ru | $rg | $win |"
  echo "$line"
  echo "$line" >> "$report"
done
echo "wrote $report"
