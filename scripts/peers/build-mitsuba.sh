#!/bin/bash
# Build the Mitsuba 0.5.0 core of the Practical Path Guiding repository
# (GitHub Tom94/practical-path-guiding) on Debian 12 with the authors' own SCons
# build, RGB mode, CPU only, for the published-scene check
# (python3 -m scripts.bench published) and the peer benchmarks.
#
# usage: scripts/peers/build-mitsuba.sh [--spectrum-fix] [--jobs N] SRC BUILD
#   SRC    a working tree of Tom94/practical-path-guiding (the folder holding mitsuba/SConstruct)
#   BUILD  a build folder: SRC/mitsuba is copied to BUILD/mitsuba and built there, so SRC stays
#          untouched and one source tree can give several builds
#   --spectrum-fix  tabulated <spectrum value="l:v, ..."> interpolated forwards inside each
#          segment, as the Mitsuba 0.6 core (and iris's default) does; without it Mitsuba 0.5.0's
#          backwards interpolation is kept (the authors' images)
#   --jobs N  compiler jobs (default 2)
#   --check-only  build only what the published-scene check needs, about half of the files: the
#          mitsuba binary, its libraries, the `path` integrator and the plugins the issue's published
#          scenes and Mitsuba's defaults use (CHECK_PLUGINS below); run again without it to build the
#          rest (guided_path, the other integrators, media, ...)
# Prints the dist folder (mitsuba binary, libraries, plugins) on its last line.
# Packages (Debian 12): scons build-essential libboost-{system,filesystem,thread}-dev
# libxerces-c-dev libeigen3-dev libopenexr-dev libpng-dev libjpeg-dev zlib1g-dev libfftw3-dev
# libglew-dev libgl1-mesa-dev libglu1-mesa-dev libxxf86vm-dev libx11-dev.
# Takes ~30 min on 2 cores; runs under nice -n 19. Re-running on the same BUILD is incremental
# (toggling --spectrum-fix recompiles one file).
set -euo pipefail
prog=build-mitsuba
here=$(cd "$(dirname "$0")" && pwd)
fix=""; jobs=2; check_only=""; args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --spectrum-fix) fix=--spectrum-fix ;;
    --jobs) shift; jobs=${1:?}; ;;
    --check-only) check_only=1 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    -*) echo "$prog: error: unknown option $1" >&2; exit 2 ;;
    *) args+=("$1") ;;
  esac
  shift
done
[ ${#args[@]} -eq 2 ] || { echo "$prog: error: usage: build-mitsuba.sh [--spectrum-fix] [--jobs N] SRC BUILD" >&2; exit 2; }
src=$(cd "${args[0]}" 2>/dev/null && pwd) || { echo "$prog: error: ${args[0]}: no such folder" >&2; exit 1; }
[ -f "$src/mitsuba/SConstruct" ] || { echo "$prog: error: $src: no mitsuba/SConstruct (give the repository's top folder)" >&2; exit 1; }
# The edits are written for the 0.5.0 core; the MARS repository (0.6 core) needs others.
grep -qs 'MTS_VERSION "0.5.0"' "$src/mitsuba/include/mitsuba/core/version.h" || {
  echo "$prog: error: $src/mitsuba is not a Mitsuba 0.5.0 core (include/mitsuba/core/version.h); only the PPG repository is supported" >&2; exit 1; }
for tool in scons g++; do command -v $tool >/dev/null || { echo "$prog: error: $tool not found (apt-get install scons build-essential ...)" >&2; exit 1; }; done
mkdir -p "${args[1]}"; build=$(cd "${args[1]}" && pwd)
tree=$build/mitsuba
if [ ! -f "$tree/SConstruct" ]; then
  echo "$prog: copying $src/mitsuba to $tree" >&2
  cp -a "$src/mitsuba" "$tree"
fi
python3 "$here/mitsuba_debian12.py" "$tree" $fix
# The plugins of the check: those the published scenes name, what Mitsuba creates by default (diffuse,
# null, gaussian, independent, hdrfilm, perspective) or internally (sunsky -> sun, sky, envmap,
# directional; obj -> bumpmap, mask, bitmap; a bitmap texture resampled to a power of two -> lanczos;
# shapegroup/instance), every reconstruction filter, and a few cheap common ones.
CHECK_PLUGINS="path
  diffuse dielectric conductor plastic roughdiffuse roughdielectric roughconductor roughplastic twosided
  mask mixturebsdf blendbsdf bumpmap phong null thindielectric
  obj ply serialized rectangle disk sphere cube cylinder shapegroup instance
  independent box gaussian tent lanczos mitchell catmullrom hdrfilm perspective
  area directional point spot constant envmap sky sun sunsky
  bitmap scale checkerboard"
targets=()
if [ -n "$check_only" ]; then
  targets=(dist/mitsuba dist/libmitsuba-core.so dist/libmitsuba-render.so dist/libmitsuba-hw.so dist/data)
  for name in $CHECK_PLUGINS; do targets+=("dist/plugins/$name.so"); done
fi
echo "$prog: scons -j$jobs ${check_only:+(${#targets[@]} targets for the check) }in $tree (log: $build/scons.log)" >&2
if ! (cd "$tree" && nice -n 19 scons -j"$jobs" "${targets[@]}" > "$build/scons.log" 2>&1); then
  echo "$prog: error: scons failed; last lines of $build/scons.log:" >&2
  tail -n 20 "$build/scons.log" >&2
  exit 1
fi
[ -x "$tree/dist/mitsuba" ] || { echo "$prog: error: scons finished but $tree/dist/mitsuba is missing" >&2; exit 1; }
version=$(LD_LIBRARY_PATH="$tree/dist" "$tree/dist/mitsuba" -h 2>&1 | grep -o 'version [0-9.]*' | head -1 || true)
echo "$prog: built Mitsuba ${version:-?} ${fix:+with the spectrum fix }in $tree/dist" >&2
echo "$tree/dist"
