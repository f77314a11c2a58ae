#!/usr/bin/env bash
# How deep to guide (issue 4): on the scenes where `auto` guides every vertex (the glass spheres and the
# mirror boxes), renders at EQUAL SPP of the unguided path tracer and of guiding the first 1, 2 and 3
# non-specular vertices and every vertex, all guided settings with Russian roulette only below throughput
# 0.1 (the deep setting's), the first vertex also with the default roulette (what `auto` weighs as its
# shallow candidate). Atlas: pipelines/guided.mk defaults. Two seeds each. Figures: relMSE less the
# reference's own noise, render seconds (scene and atlas loading excluded), and efficiency
# 1 / (relMSE x seconds), summed over both seeds, relative to unguided.
# Usage: scripts/bench-depth.sh [SPP]   (default 64; needs a Release build in build/ and the half-resolution
# references: make -f pipelines/bench.mk references). Writes docs/benchmarks/depth.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench-lib.sh
spp=${1:-64}
out=${IRIS_OUT:-out/bench}/depth
report=docs/benchmarks/depth.md
mkdir -p "$out" docs/benchmarks
settings=(
  "unguided|--mode nee+bsdf"
  "first vertex|--guide-vertices 1"
  "first vertex, rr 0.1|--guide-vertices 1 --rr-threshold 0.1"
  "first 2, rr 0.1|--guide-vertices 2 --rr-threshold 0.1"
  "first 3, rr 0.1|--guide-vertices 3 --rr-threshold 0.1"
  "every vertex, rr 0.1|--guide-vertices 0 --rr-threshold 0.1"
)
{
  echo "## Guiding depth: noise per sample and cost"
  echo
  echo "\`scripts/bench-depth.sh $spp\`, $(date -u +%Y-%m-%d), $(nproc) threads, $spp spp at half resolution, seeds 3 and 4"
  echo "(figures: seed 3 / seed 4). relMSE less the reference's own noise; efficiency = 1 / (relMSE x seconds),"
  echo "summed over both seeds, relative to unguided. *rr 0.1*: Russian roulette only below throughput 0.1."
  echo
  echo "| scene | setting | relMSE | seconds | efficiency vs unguided |"
  echo "|---|---|---|---|---|"
} > "$report"
for s in cbox_kugeln.xml cbox_spiegelboxen.xml; do
  name=$(basename "${s%.xml}")
  scene=$seeds/$s
  ref=.cache/references/$name-s0.5-2048spp.exr
  res=$(scaled_resolution "$scene" 0.5)
  make -s -f pipelines/guided.mk SCENE="$scene" OUT="$out/$name" BIN="$bin" MIN_CAUSTIC=0 atlas >/dev/null 2>&1
  base=""
  for c in "${settings[@]}"; do
    IFS='|' read -r label flags <<< "$c"
    # shellcheck disable=SC2206
    args=($flags)
    [ "$label" = unguided ] || args=(--mode nee+bsdf+cache --atlas "$out/$name/atlas.h5" "${args[@]}")
    e=""; t=""; work=0
    for seed in 3 4; do
      img=$out/$name-seed$seed.exr
      "$bin/render" "$scene" -o "$img" --spp "$spp" --resolution "$res" --seed $seed -q "${args[@]}" 2>/dev/null
      secs=$(render_seconds "$img")
      read -r err _ < <(relmse_less_reference_noise "$img" "$ref")
      e+="${e:+ / }$(printf %.4f "$err")"; t+="${t:+ / }$(printf %.2f "$secs")"
      work=$(awk -v w="$work" -v a="$err" -v b="$secs" 'BEGIN{print w + a * b}')
    done
    [ -z "$base" ] && base=$work
    row="| $name | $label | $e | $t | $(awk -v a="$base" -v b="$work" 'BEGIN{printf "%.2fx", a / b}') |"
    echo "$row"
    echo "$row" >> "$report"
  done
done
echo "wrote $report"
