# Shared by the scripts/bench-*.sh benchmarks (sourced, not run): where the thesis scenes and the Release
# binaries are, and the few measurements every script reads the same way.
seeds=scenes/thesis
bin=build/bin
# Median of the numbers on stdin, one per line.
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
# Wall seconds of a render itself (scene and atlas loading excluded), from the image's metadata.
render_seconds() { render_field "$1" iris:seconds; }
# One metadata field of a render (e.g. iris:rays).
render_field() { "$bin/compare-images" "$1" --metadata | awk -v k="$2" '$1 == k {print $2}'; }
# WxH of SCENE's film scaled by SCALE, as the tiered benchmark renders it (scripts/bench.py).
scaled_resolution() {
  python3 -c "import sys; sys.path.insert(0, 'scripts'); import bench; print('%dx%d' % bench.scaled_resolution(sys.argv[1], float(sys.argv[2])))" "$1" "$2"
}
# relMSE of IMAGE against REF less the reference's own share (its variance layers), and the trimmed relMSE.
relmse_less_reference_noise() {
  "$bin/compare-images" "$1" "$2" --json |
    python3 -c "import json,sys; d=json.load(sys.stdin); print(d['relmse'] - d['relmse_reference_noise'], d['relmse_trimmed'])"
}
# The "References." paragraph of a report measured against REF, a long render checked against an
# independent OTHER: each one's own share of a relMSE (from its variance layers), the relMSE between them
# and what their noise alone would give (the sum of the two shares; equal means they differ by noise only).
#   reference_paragraph REF "how REF was made" OTHER "how OTHER was made" "which the tables use"
reference_paragraph() {
  local to_other back spp share_ref share_other between
  to_other=$("$bin/compare-images" "$1" "$3" --json)
  back=$("$bin/compare-images" "$3" "$1" --json)
  spp=$(render_field "$1" iris:spp)
  read -r share_ref share_other between <<<"$(python3 -c "import json,sys; a, b = json.loads(sys.argv[1]), json.loads(sys.argv[2]); print('%.4g %.4g %.4g' % (b['relmse_reference_noise'], a['relmse_reference_noise'], a['relmse']))" "$to_other" "$back")"
  echo "**References.** $2 ($spp spp; its own share of a relMSE $share_ref) against $4 (share $share_other): relMSE"
  echo "between them $between, expected from their noise alone $(awk "BEGIN {printf \"%.4g\", $share_ref + $share_other}")"
  echo "(the sum of the two shares). $5"
}
