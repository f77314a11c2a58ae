#!/usr/bin/env bash
# Where the per-sample cost of guided rendering comes from (issue 4): per guided seed scene, the seconds
# per sample of four settings at equal spp, median of 5 interleaved runs, side by side in one run:
#   unguided            nee+bsdf with the default Russian roulette (the benchmark's baseline)
#   unguided, rr 0.1    the same with the deep setting's roulette (survival below throughput 0.1 only)
#   first vertex        nee+bsdf+cache guiding the first non-specular vertex (default roulette)
#   every vertex        nee+bsdf+cache guiding every vertex with roulette below 0.1 (auto's deep setting)
# so that the deep setting's cost splits into its longer paths (rr 0.1 / unguided) and the guiding
# itself (every vertex / rr 0.1). Caches: pipelines/guided.mk defaults, forced (MIN_CAUSTIC=0).
# Usage: scripts/bench-cost.sh [SPP] [SCALE]   (defaults 16 and 0.5; needs a Release build in build/)
# Writes docs/benchmarks/cost.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench-lib.sh
spp=${1:-16}
scale=${2:-0.5}
out=${IRIS_OUT:-out/bench}/cost
report=docs/benchmarks/cost.md
mkdir -p "$out" docs/benchmarks
scenes=(cbox_kugeln.xml cbox_spiegelboxen.xml veach_bidir/bidir.xml metal_ring/ring.xml)
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.2fx", a / b}'; }
# Time per ray of setting $1 relative to unguided, and a count per sample (both read the loop's t, rays, samples).
per_ray() { awk -v ta="${t[$1]}" -v ra="${rays[$1]}" -v tu="${t[unguided]}" -v ru="${rays[unguided]}" \
  'BEGIN {printf "%.2fx", (ta / ra) / (tu / ru)}'; }
per_sample() { awk -v n="$1" -v s="$samples" 'BEGIN {printf "%.2f", n / s}'; }
{
  echo "## Per-sample cost of guided rendering, decomposed"
  echo
  echo "\`scripts/bench-cost.sh $spp $scale\`, $(date -u +%Y-%m-%d), $(nproc) threads, $spp spp at scale $scale, median"
  echo "of 5 interleaved runs (render's own seconds). Ratios are to the unguided path tracer with the default roulette"
  echo "unless named: *paths* = unguided with roulette below 0.1 / unguided (the deep setting's longer paths),"
  echo "*guiding* = every vertex / unguided with roulette below 0.1 (lookups and cache sampling at every vertex)."
  echo
  echo "| scene | unguided (s) | unguided, rr 0.1 (s) | first vertex (s) | every vertex (s) | first vertex | every vertex | paths | guiding |"
  echo "|---|---|---|---|---|---|---|---|---|"
} > "$report"
# The second table splits each setting's cost per sample into rays per sample and time per ray (the
# render's own counters, iris:rays and iris:cache_lookups, of the seed-1 render; seeds change them little):
# guiding changes where paths go, and a guided path that follows light through glass casts more rays.
rays_table="$out/rays-table.md"
{
  echo
  echo "Rays per sample and time per ray, relative to unguided (the first table's ratio = rays x time per ray),"
  echo "and the cache lookups per sample:"
  echo
  echo "| scene | rays/sample unguided | rays: rr 0.1 / first / every | time per ray: rr 0.1 / first / every | lookups/sample: first / every |"
  echo "|---|---|---|---|---|"
} > "$rays_table"
# The third table (only where perf can sample the CPU clock): where the every-vertex setting's extra
# time goes, by binary -- Embree's ray queries, iris's own code (the guide's lookups, densities and
# samples, and the rest of the path tracer), everything else -- from profiled renders of seeds 1-3 per
# setting, interleaved. perf's counts are CPU time and include loading the scene and the atlas, which
# render's seconds (wall time of the render alone) exclude.
have_perf=0
if command -v perf > /dev/null && perf record -q -e cpu-clock -o /dev/null true > /dev/null 2>&1; then have_perf=1; fi
perf_table="$out/perf-table.md"
{
  echo
  echo "Where the every-vertex setting's extra time goes (\`perf record -e cpu-clock\`, seeds 1-3 interleaved,"
  echo "samples summed; relative to all of the rr-0.1 renders' samples, loading included): the extra samples in"
  echo "Embree, in iris's own code and elsewhere, and Embree's samples per ray (every vertex / rr 0.1, rays of seed 1):"
  echo
  echo "| scene | extra samples | Embree | iris | other | Embree per ray |"
  echo "|---|---|---|---|---|---|"
} > "$perf_table"
# Samples of a profiled render (args: OUT.exr, render arguments...): "total embree iris" on stdout.
perf_split() {
  local exr=$1; shift
  perf record -q -e cpu-clock -F 2000 -o "$exr.perf" "$bin/render" "$@" -o "$exr" -q > /dev/null 2>&1
  perf report -i "$exr.perf" --no-children --sort dso --stdio -n -g none 2>/dev/null |
    awk '/^ +[0-9.]+%/ {t += $2; if ($3 ~ /^libembree/) e += $2; if ($3 == "render") r += $2} END {print t, e, r}'
  rm -f "$exr.perf"
}
for s in "${scenes[@]}"; do
  name=$(basename "${s%.xml}")
  scene=$seeds/$s
  res=$(scaled_resolution "$scene" "$scale")
  make -s -f pipelines/guided.mk SCENE="$scene" OUT="$out/$name" BIN="$bin" MIN_CAUSTIC=0 atlas
  atlas=$out/$name/atlas.h5
  declare -A t=() rays=() lookups=()
  settings=(unguided rr01 first every)
  for rep in 1 2 3 4 5; do
    for k in "${settings[@]}"; do
      case $k in
        unguided) args=(--mode nee+bsdf) ;;
        rr01) args=(--mode nee+bsdf --rr-threshold 0.1) ;;
        first) args=(--mode nee+bsdf+cache --atlas "$atlas" --guide-vertices 1) ;;
        every) args=(--mode nee+bsdf+cache --atlas "$atlas" --guide-vertices 0 --rr-threshold 0.1) ;;
      esac
      "$bin/render" "$scene" -o "$out/$name/$k.exr" --spp "$spp" --resolution "$res" --seed "$rep" -q "${args[@]}"
      t[$k]+="$(render_seconds "$out/$name/$k.exr") "
      if [ $rep = 1 ]; then  # the counters depend on the seed, not on the machine: one render's suffice
        rays[$k]=$(render_field "$out/$name/$k.exr" iris:rays)
        lookups[$k]=$(render_field "$out/$name/$k.exr" iris:cache_lookups)
      fi
    done
  done
  for k in "${settings[@]}"; do t[$k]=$(echo ${t[$k]} | tr ' ' '\n' | median); done
  row="| $name | ${t[unguided]} | ${t[rr01]} | ${t[first]} | ${t[every]} | $(ratio ${t[first]} ${t[unguided]}) | $(ratio ${t[every]} ${t[unguided]}) | $(ratio ${t[rr01]} ${t[unguided]}) | $(ratio ${t[every]} ${t[rr01]}) |"
  echo "$row"
  echo "$row" >> "$report"
  samples=$(python3 -c "print(${res/x/*} * $spp)")
  echo "| $name | $(per_sample ${rays[unguided]}) | $(ratio ${rays[rr01]} ${rays[unguided]}) / $(ratio ${rays[first]} ${rays[unguided]}) / $(ratio ${rays[every]} ${rays[unguided]}) | $(per_ray rr01) / $(per_ray first) / $(per_ray every) | $(per_sample ${lookups[first]}) / $(per_sample ${lookups[every]}) |" >> "$rays_table"
  if [ $have_perf = 1 ]; then
    pt_rr=0 pe_rr=0 pr_rr=0 pt_ev=0 pe_ev=0 pr_ev=0
    for seed in 1 2 3; do  # interleaved, the samples summed over three seeds
      read -r a b c < <(perf_split "$out/$name/perf-rr01.exr" "$scene" --spp "$spp" --resolution "$res" --seed $seed \
        --mode nee+bsdf --rr-threshold 0.1)
      pt_rr=$((pt_rr + a)) pe_rr=$((pe_rr + b)) pr_rr=$((pr_rr + c))
      read -r a b c < <(perf_split "$out/$name/perf-every.exr" "$scene" --spp "$spp" --resolution "$res" --seed $seed \
        --mode nee+bsdf+cache --atlas "$atlas" --guide-vertices 0 --rr-threshold 0.1)
      pt_ev=$((pt_ev + a)) pe_ev=$((pe_ev + b)) pr_ev=$((pr_ev + c))
    done
    awk -v n="$name" -v tr="$pt_rr" -v er="$pe_rr" -v rr="$pr_rr" -v te="$pt_ev" -v ee="$pe_ev" -v re="$pr_ev" \
      -v yr="${rays[rr01]}" -v ye="${rays[every]}" \
      'BEGIN {printf "| %s | +%.2fx | +%.2fx | +%.2fx | +%.2fx | %.2fx |\n", n, (te - tr) / tr, (ee - er) / tr,
              (re - rr) / tr, ((te - ee - re) - (tr - er - rr)) / tr, (ee / ye) / (er / yr)}' >> "$perf_table"
  fi
  unset t rays lookups
done
cat "$rays_table" >> "$report"
cat "$rays_table"
if [ $have_perf = 1 ]; then cat "$perf_table" >> "$report"; cat "$perf_table"; fi
echo "wrote $report"
