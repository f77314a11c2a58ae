#!/usr/bin/env bash
# What a guided vertex costs in instructions and mispredicted branches (issue 4), counted rather than
# timed: this VM's timings of one render swing by +-10 % between identical runs, which hides a change
# of a few percent; valgrind's cachegrind counts the same on every run. Per guided seed scene, 64x64
# pixels, one thread, seed 1, two settings (as scripts/bench-cost.sh names them):
#   rr 0.1        nee+bsdf with Russian roulette only below throughput 0.1
#   every vertex  nee+bsdf+cache guiding every vertex, the same roulette
# Each setting is rendered at 8 and at 24 spp and the counts subtracted, so that loading the scene and
# the atlas and building the guide drop out: the figures are those of 16 spp of rendering. Cachegrind's
# branch predictor is a simple model (not this CPU's), so its mispredictions are a guide to where they
# are, not a count of this CPU's; memory stalls (the other part of a guided vertex's time) are not
# counted at all (scripts/bench-cost.sh's perf table and the notes in docs/BENCHMARKS.md cover them).
# Caches: the atlases scripts/bench-cost.sh built (out/bench/cost/*/atlas.h5; run it first).
# Usage: scripts/bench-instructions.sh [BIN_DIR]   (default build/bin; needs valgrind)
# Writes docs/benchmarks/instructions.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench-lib.sh
bin=${1:-$bin}
command -v valgrind > /dev/null || { echo "bench-instructions: needs valgrind (apt-get install valgrind)" >&2; exit 1; }
out=${IRIS_OUT:-out/bench}/instructions
cost=${IRIS_OUT:-out/bench}/cost
report=docs/benchmarks/instructions.md
mkdir -p "$out" docs/benchmarks
scenes=(cbox_kugeln.xml cbox_spiegelboxen.xml veach_bidir/bidir.xml metal_ring/ring.xml)
# Runs cachegrind on one render (args: NAME SPP render-arguments...); leaves $out/NAME-SPP.cg.
# IRIS_REUSE=1 keeps the counts of an earlier run (to rewrite the report only).
count() {
  local name=$1 spp=$2; shift 2
  [[ -n "${IRIS_REUSE:-}" && -f "$out/$name-$spp.cg" ]] && return
  valgrind --tool=cachegrind --cache-sim=no --branch-sim=yes --cachegrind-out-file="$out/$name-$spp.cg" \
    "$bin/render" "$@" -o "$out/$name-$spp.exr" --spp "$spp" --resolution 64x64 --seed 1 --threads 1 -q > /dev/null 2>&1
}
# Instructions and conditional-branch mispredictions of a cachegrind file: "IR BCM".
totals() { cg_annotate "$1" | awk '/PROGRAM TOTALS/ {gsub(/,/, "", $1); gsub(/,/, "", $5); print $1, $5}'; }
# Instructions per function of a cachegrind file: "IR<TAB>function".
per_function() {
  cg_annotate --threshold=0 --show=Ir "$1" | awk '/file:function/ {p = 1; next}
    p && /^ *[0-9,]+ \(/ {x = $1; gsub(/,/, "", x); sub(/^ *[0-9,]+ \( *[0-9.]+%\) +/, ""); sub(/^[^:]*:/, ""); print x "\t" $0}'
}
{
  echo "## Instructions and mispredicted branches of guided rendering"
  echo
  echo "\`scripts/bench-instructions.sh\`, $(date -u +%Y-%m-%d), valgrind's cachegrind (branch simulation on), 64x64, one thread,"
  echo "seed 1; counts of 16 spp of rendering (a 24-spp render less an 8-spp one: loading and set-up drop out). *rr 0.1*:"
  echo "unguided with Russian roulette below throughput 0.1; *every vertex*: guided at every vertex, the same roulette."
  echo "Per guided vertex: the every-vertex setting's extra over rr 0.1, divided by its cache lookups."
  echo
  echo "| scene | instructions: rr 0.1 / every vertex | ratio | mispredicted branches: rr 0.1 / every vertex | lookups | extra instructions per lookup | extra mispredictions per lookup |"
  echo "|---|---|---|---|---|---|---|"
} > "$report"
split="$out/split.md"
{
  echo
  echo "Where a lookup's extra instructions go (every vertex less rr 0.1, per lookup; functions with at least 10;"
  echo "*path tracer* is trace_path and what the compiler inlined into it, *Embree* the code without symbols, Embree's traversal):"
  echo
} > "$split"
for s in "${scenes[@]}"; do
  name=$(basename "${s%.xml}")
  atlas=$cost/$name/atlas.h5
  [ -f "$atlas" ] || { echo "bench-instructions: no $atlas (run scripts/bench-cost.sh first)" >&2; exit 1; }
  for spp in 8 24; do
    count "$name-rr01" "$spp" "$seeds/$s" --mode nee+bsdf --rr-threshold 0.1
    count "$name-every" "$spp" "$seeds/$s" --mode nee+bsdf+cache --atlas "$atlas" --guide-vertices 0 --rr-threshold 0.1
  done
  read -r u8 ub8 <<< "$(totals "$out/$name-rr01-8.cg")"
  read -r u24 ub24 <<< "$(totals "$out/$name-rr01-24.cg")"
  read -r g8 gb8 <<< "$(totals "$out/$name-every-8.cg")"
  read -r g24 gb24 <<< "$(totals "$out/$name-every-24.cg")"
  l8=$(render_field "$out/$name-every-8.exr" iris:cache_lookups)
  l24=$(render_field "$out/$name-every-24.exr" iris:cache_lookups)
  row=$(awk -v n="$name" -v u=$((u24 - u8)) -v g=$((g24 - g8)) -v ub=$((ub24 - ub8)) -v gb=$((gb24 - gb8)) -v l=$((l24 - l8)) \
    'BEGIN {printf "| %s | %.0fM / %.0fM | %.2fx | %.0fk / %.0fk | %d | %.0f | %.1f |", n, u / 1e6, g / 1e6, g / u, ub / 1e3, gb / 1e3, l, (g - u) / l, (gb - ub) / l}')
  echo "$row"
  echo "$row" >> "$report"
  for k in rr01-8 rr01-24 every-8 every-24; do per_function "$out/$name-$k.cg" > "$out/$name-$k.fn"; done
  {
    printf '%s: ' "$name"
    awk -F'\t' -v l=$((l24 - l8)) '
      FILENAME ~ /rr01-8/ {a[$2] -= $1} FILENAME ~ /rr01-24/ {a[$2] += $1}
      FILENAME ~ /every-8/ {b[$2] -= $1} FILENAME ~ /every-24/ {b[$2] += $1}
      END {
        for (f in b) d[f] = b[f] - a[f]
        for (f in a) if (!(f in b)) d[f] = -a[f]
        for (f in d) {
          n = f
          if (n ~ /parallel_for_body_wrapper<iris::render_image/ || n ~ /^iris::trace_path\(/) n = "path tracer"
          else if (match(n, /at_resolution<iris::Guide::[a-z_]+/)) n = "Guide::" substr(n, RSTART + 27, RLENGTH - 27)
          else if (n == "???") n = "Embree"
          else { gsub(/\(anonymous namespace\)::/, "", n); sub(/\(.*/, "", n); sub(/^iris::/, "", n) }
          e[n] += d[f] / l
        }
        for (n in e) if (e[n] >= 10 || e[n] <= -10) printf "%.0f\t%s\n", e[n], n
      }' "$out/$name-rr01-8.fn" "$out/$name-rr01-24.fn" "$out/$name-every-8.fn" "$out/$name-every-24.fn" |
      sort -rn | awk -F'\t' '{printf "%s%s %+d", (NR > 1 ? ", " : ""), $2, $1} END {print ""}'
    echo
  } >> "$split"
done
cat "$split" >> "$report"
echo "wrote $report"
