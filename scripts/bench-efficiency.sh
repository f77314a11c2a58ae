#!/usr/bin/env bash
# Equal-time efficiency of the default pipeline against the unguided tracer, side by side (docs/benchmarks/efficiency.md):
#   scripts/bench-efficiency.sh NAME SCENE WxH REFERENCE.exr BUDGETS REPEATS BIN_DIR...
# For each binary directory (e.g. an old build and the current one): the guided pipeline's preprocessing
# (pipelines/guided.mk defaults, its stage seconds in out/eff-NAME.prep), then for every repeat and total
# budget B (seconds, comma-separated) one render per binary and mode -- guided (`render --mode auto`, B minus
# the preprocessing) and unguided (`--mode nee+bsdf`, B) -- all interleaved, the order rotated each repeat
# (a shared machine drifts). Each render is compared with the reference; one line per render in
# out/eff-NAME.tsv: name, binary, mode, budget, repeat, total s (render wall + preprocessing), spp,
# sampling s, relMSE, 1-minute load average. scripts/bench-efficiency-summary.py tabulates the medians.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out
name=$1 scene=$2 res=$3 ref=$4 budgets=$5 reps=$6; shift 6; bins=("$@")
tsv=out/eff-$name.tsv; : > $tsv; : > out/eff-$name.prep
for b in "${bins[@]}"; do
  o=out/eff-$name/$(basename $b); rm -rf $o; mkdir -p $o
  make -s -f pipelines/guided.mk SCENE=$scene OUT=$o BIN=$b atlas > /dev/null 2>&1
  prep=$(cat $o/photons.seconds $o/caches.seconds $o/atlas.seconds | awk '{s+=$1} END{printf "%.3f", s}')
  echo "$b prep $prep $(cat $o/photons.seconds $o/caches.seconds $o/atlas.seconds | tr '\n' ' ')" >> out/eff-$name.prep
done
for r in $(seq $reps); do
  for B in ${budgets//,/ }; do
    jobs=()
    for b in "${bins[@]}"; do jobs+=("$b nee+bsdf" "$b auto"); done
    n=${#jobs[@]}
    for k in $(seq 0 $((n-1))); do
      j=${jobs[$(( (k + r - 1) % n ))]}; set -- $j; b=$1 m=$2
      o=out/eff-$name/$(basename $b)
      prep=$(cat $o/photons.seconds $o/caches.seconds $o/atlas.seconds | awk '{s+=$1} END{printf "%.3f", s}')
      img=$o/${m/+/_}-${B}s-r$r.exr
      if [ $m = auto ]; then t=$(awk -v a=$B -v p=$prep 'BEGIN{printf "%.3f", a-p}'); x="--atlas $o/atlas.h5 --mode auto"; else t=$B; x="--mode nee+bsdf"; prep=0; fi
      s0=$(date +%s.%N)
      $b/render $scene -o $img --resolution $res --time $t --seed $((6 + r)) -q --no-scene-warnings $x
      s1=$(date +%s.%N)
      total=$(awk -v a=$s0 -v b=$s1 -v p=$prep 'BEGIN{printf "%.2f", b-a+p}')
      rel=$(build/bin/compare-images $img $ref --json | sed -n 's/.*"relmse": \([0-9.e+-]*\),.*/\1/p')
      spp=$(build/bin/compare-images $img --metadata | sed -n 's/^iris:spp //p')
      secs=$(build/bin/compare-images $img --metadata | sed -n 's/^iris:seconds //p')
      load=$(cut -d' ' -f1 /proc/loadavg)
      printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n" $name $(basename $b) $m $B $r $total $spp $secs $rel $load >> $tsv
    done
  done
done
