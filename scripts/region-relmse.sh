#!/usr/bin/env bash
# scripts/region-relmse.sh TEST.exr REFERENCE.exr: relMSE of the 256 x 256 glass box (scenes/cbox/glass_spheres.xml,
# --resolution 256x256) per region, and each region's share of the image's summed relMSE (compare-images --mask
# leaves out everything but the region). Regions (pixel rectangles, half-open): the left sphere, the right sphere,
# the floor with the caustics, the rest (walls, ceiling, back wall; the two sphere boxes overlap by 10 x 26 px).
set -euo pipefail
cd "$(dirname "$0")/.."
t=$1; r=$2; W=256; H=256
keep() { local x0=$1 y0=$2 x1=$3 y1=$4; local m=()
  [ $y0 -gt 0 ] && m+=(--mask 0,0,$W,$y0); [ $y1 -lt $H ] && m+=(--mask 0,$y1,$W,$H)
  [ $x0 -gt 0 ] && m+=(--mask 0,$y0,$x0,$y1); [ $x1 -lt $W ] && m+=(--mask $x1,$y0,$W,$y1); echo "${m[@]}"; }
rel() { build/bin/compare-images "$t" "$r" --json "$@" | sed -n 's/.*"relmse": \([0-9.e+-]*\),.*/\1/p'; }
all=$(rel)
declare -A R=([sphere_l]="78 42 132 98" [sphere_r]="122 72 188 138" [floor]="20 168 236 240")
printf "%-9s %10s %7s %6s\n" region relMSE pixels share
printf "%-9s %10s %7d %6s\n" all $all $((W*H)) 1.00
for k in sphere_l sphere_r floor; do set -- ${R[$k]}; v=$(rel $(keep $1 $2 $3 $4)); n=$(( ($3-$1)*($4-$2) ))
  awk -v k=$k -v v=$v -v n=$n -v a=$all -v N=$((W*H)) 'BEGIN{printf "%-9s %10.4g %7d %6.2f\n", k, v, n, v*n/(a*N)}'; done
v=$(rel --mask 78,42,132,98 --mask 122,72,188,138 --mask 20,168,236,240)
n=$((W*H - 54*56 - 66*66 - 216*72 + 10*26))
awk -v v=$v -v n=$n -v a=$all -v N=$((W*H)) 'BEGIN{printf "%-9s %10.4g %7d %6.2f  (walls, ceiling; overlaps approximate)\n", "rest", v, n, v*n/(a*N)}'
