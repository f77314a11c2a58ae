#!/usr/bin/env bash
# Map resolution against noise per sample (issue 4): per guided seed scene, the cache atlas built with the
# pipeline's defaults (pipelines/guided.mk) except RES, and renders at EQUAL SPP of the unguided path
# tracer and of guiding with each atlas, in the setting `auto` picked there with 16x16 maps (every vertex
# with roulette below 0.1 on the glass spheres and the mirror boxes, the first vertex on the ring and the
# egg; with 32x32 maps it guides every vertex on the egg too).
# Two seeds each. Figures: relMSE less the reference's own noise (compare-images), trimmed relMSE, render
# seconds, and efficiency 1 / (relMSE x seconds) relative to unguided. Equal spp separates the quality of
# the maps from the time budget; seconds are the render's own (scene and atlas loading excluded).
# Usage: scripts/bench-resolution.sh [SPP] [RESOLUTIONS]   (defaults 64 and "16 32"; the spheres also get
# 24 and 64). Needs a Release build in build/ and the half-resolution references (make -f
# pipelines/bench.mk references). Writes docs/benchmarks/resolution.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench-lib.sh
spp=${1:-64}
resolutions=${2:-16 32}
out=${IRIS_OUT:-out/bench}/resolution
report=docs/benchmarks/resolution.md
mkdir -p "$out" docs/benchmarks
# scene, the guided setting auto picks there, the extra map resolutions tried
cases=(
  "cbox_kugeln.xml|--guide-vertices 0 --rr-threshold 0.1|24 64"
  "cbox_spiegelboxen.xml|--guide-vertices 0 --rr-threshold 0.1|"
  "metal_ring/ring.xml|--guide-vertices 1|"
  "veach_bidir/bidir.xml|--guide-vertices 1|"
)
{
  echo "## Map resolution: noise per sample and cost"
  echo
  echo "\`scripts/bench-resolution.sh $spp \"$resolutions\"\`, $(date -u +%Y-%m-%d), $(nproc) threads, $spp spp at half resolution,"
  echo "seeds 3 and 4 (figures: seed 3 / seed 4). Atlas: pipelines/guided.mk defaults but RES. relMSE less the"
  echo "reference's own noise; efficiency = 1 / (relMSE x seconds), summed over both seeds, relative to unguided."
  echo
  echo "| scene | setting | maps | relMSE | trimmed relMSE | seconds | efficiency vs unguided |"
  echo "|---|---|---|---|---|---|---|"
} > "$report"
for c in "${cases[@]}"; do
  IFS='|' read -r s setting extra <<< "$c"
  name=$(basename "${s%.xml}")
  scene=$seeds/$s
  ref=.cache/references/$name-s0.5-2048spp.exr
  res=$(scaled_resolution "$scene" 0.5)
  base=""
  for r in unguided $resolutions $extra; do
    if [ "$r" = unguided ]; then
      args=(--mode nee+bsdf)
    else
      make -s -f pipelines/guided.mk SCENE="$scene" OUT="$out/$name-R$r" BIN="$bin" RES="$r" MIN_CAUSTIC=0 atlas >/dev/null 2>&1
      # shellcheck disable=SC2206
      args=(--mode nee+bsdf+cache --atlas "$out/$name-R$r/atlas.h5" $setting)
    fi
    e=""; t=""; m=""; work=0
    for seed in 3 4; do
      img=$out/$name-$r-$seed.exr
      "$bin/render" "$scene" -o "$img" --spp "$spp" --resolution "$res" --seed $seed -q "${args[@]}" 2>/dev/null
      secs=$(render_seconds "$img")
      read -r err trim < <(relmse_less_reference_noise "$img" "$ref")
      e+="${e:+ / }$(printf %.4f "$err")"; m+="${m:+ / }$(printf %.4f "$trim")"; t+="${t:+ / }$(printf %.2f "$secs")"
      work=$(awk -v w="$work" -v a="$err" -v b="$secs" 'BEGIN{print w + a * b}')
    done
    [ -z "$base" ] && base=$work
    label=$([ "$r" = unguided ] && echo "-" || echo "${r}x$r")
    row="| $name | $([ "$r" = unguided ] && echo unguided || echo "$setting") | $label | $e | $m | $t | $(awk -v a="$base" -v b="$work" 'BEGIN{printf "%.2fx", a / b}') |"
    echo "$row"
    echo "$row" >> "$report"
  done
done
echo "wrote $report"
