#!/usr/bin/env bash
# Throughput benchmark of `render` against raw Embree on every seed scene at its own resolution:
# paths/s and rays/s of the path tracer (median of 3 runs) beside bench-rays' closest-hit rate for
# incoherent rays on the same scene, measured side by side in one run. Writes docs/BENCHMARKS.md's
# throughput section (docs/benchmarks/throughput.md).
# Usage: scripts/bench-throughput.sh [SPP]   (default 4; needs a Release build in build/)
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench-lib.sh
spp=${1:-4}
out=${IRIS_OUT:-out/bench}
mkdir -p "$out" docs/benchmarks
scenes=(cbox_kugeln.xml cbox_nur_box.xml cbox_spiegelboxen.xml cbox_diffuse_boxes.xml veach_bidir/bidir.xml
        veach_mi/mi.xml veach_mi/mi_ohne_bretter.xml metal_ring/ring.xml)
threads=$(nproc)
report=docs/benchmarks/throughput.md
{
  echo "## Path-tracer throughput against raw Embree"
  echo
  echo "\`scripts/bench-throughput.sh $spp\`, $(date -u +%Y-%m-%d), $threads threads ($(lscpu | sed -n 's/^Model name: *//p' | head -1))."
  echo "render: NEE+BSDF MIS at $spp spp, the scene's own resolution and depth settings, median of 3 runs."
  echo "Raw Embree: \`bench-rays\`, incoherent closest-hit rays from visible surface points in uniform random"
  echo "directions, median of 3 runs. The ratio compares render's rays/s (closest-hit + shadow rays, with all"
  echo "shading, sampling and film work included) with raw Embree's rays/s."
  echo
  echo "| scene | resolution | Mpaths/s | Mrays/s (render) | Mrays/s (raw Embree) | ratio |"
  echo "|---|---|---|---|---|---|"
} > "$report"
for s in "${scenes[@]}"; do
  paths=(); rays=()
  for i in 1 2 3; do
    line=$("$bin/render" "$seeds/$s" -o "$out/tp.exr" --spp "$spp" --seed $i 2>&1 | grep "render: wrote")
    paths+=("$(echo "$line" | sed -n 's/.* \([0-9.]*\) Mpaths\/s.*/\1/p')")
    rays+=("$(echo "$line" | sed -n 's/.* \([0-9.]*\) Mrays\/s.*/\1/p')")
    res=$(echo "$line" | sed -n 's/.*(\([0-9]*x[0-9]*\),.*/\1/p')
  done
  p=$(printf '%s\n' "${paths[@]}" | median)
  r=$(printf '%s\n' "${rays[@]}" | median)
  raw=$("$bin/bench-rays" "$seeds/$s" --rays 4000000 --repeats 3 | sed -n 's/.*: \([0-9.]*\) Mrays\/s.*/\1/p')
  ratio=$(awk -v a="$r" -v b="$raw" 'BEGIN {printf "%.0f %%", 100 * a / b}')
  echo "$s: $p Mpaths/s, $r Mrays/s, raw $raw Mrays/s, $ratio"
  echo "| \`$s\` | $res | $p | $r | $raw | $ratio |" >> "$report"
done
echo "wrote $report"
