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
