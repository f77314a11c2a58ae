#!/usr/bin/env bash
# Regenerates the per-stage golden files of tests/golden/ (DESIGN.md section 7, "golden files per
# stage"): the outputs of each pipeline stage on the tiny caustic scene at a fixed seed, which the
# pipeline tests (tests/pipeline/test_golden_stages.cpp) reproduce stage by stage, each from the golden
# output of the stage before, under stated tolerances.
#
# What it runs (arguments from stages.args, from the repository root, so that the provenance in the
# files records relative paths):
#   trace-photons SCENE                                     -> photons.h5
#   place-caches  SCENE --photon-map photons.h5             -> caches.h5
#   fill-caches   caches.h5 --photon-map photons.h5         -> atlas.h5
#   render        SCENE --atlas atlas.h5 --variance         -> render.exr
#
# When to run it: after a deliberate change to a stage's results -- its algorithm, its random number
# use, a file format version, the scene file or stages.args -- once you have convinced yourself that
# the new results are right (the statistical tests pass, the differences the golden tests report are
# the ones you meant). Commit the regenerated files with the change and say why in the message. Never
# regenerate to silence a golden test you cannot explain.
#
# Usage: tests/golden/regenerate.sh [BIN_DIR]    (default: $IRIS_BIN_DIR, else build/bin)
# Also: make -C tests/golden
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
bin="${1:-${IRIS_BIN_DIR:-$repo/build/bin}}"
bin="$(cd "$bin" && pwd)"
for t in trace-photons place-caches fill-caches render; do
  [[ -x "$bin/$t" ]] || { echo "regenerate.sh: error: $bin/$t not found (build first, or pass the bin directory)" >&2; exit 1; }
done
args() { sed -n "s/^$1 //p" "$here/stages.args"; }
cd "$repo"
scene="$(args scene)"
rel="tests/golden"
files=(photons.h5 caches.h5 atlas.h5 render.exr)
# Keep the current files until every stage has succeeded: on any failure they are put back, so the
# folder never holds outputs of two different runs.
backup="$(mktemp -d)"
for f in "${files[@]}"; do [[ -e "$rel/$f" ]] && mv "$rel/$f" "$backup/"; done
restore() {
  echo "regenerate.sh: error: a stage failed; the previous golden files are kept" >&2
  for f in "${files[@]}"; do rm -f "$rel/$f"; [[ -e "$backup/$f" ]] && mv "$backup/$f" "$rel/"; done
  rm -rf "$backup"
}
trap restore ERR
# A fixed creation time, for fewer spurious differences (the stages still record their run time).
export SOURCE_DATE_EPOCH=0
read -ra trace_args <<<"$(args trace-photons)"
read -ra place_args <<<"$(args place-caches)"
read -ra fill_args <<<"$(args fill-caches)"
read -ra render_args <<<"$(args render)"
"$bin/trace-photons" "$scene" -q "${trace_args[@]}" -o "$rel/photons.h5"
"$bin/place-caches" "$scene" -q --photon-map "$rel/photons.h5" "${place_args[@]}" -o "$rel/caches.h5"
"$bin/fill-caches" "$rel/caches.h5" -q --photon-map "$rel/photons.h5" "${fill_args[@]}" -o "$rel/atlas.h5"
"$bin/render" "$scene" -q --atlas "$rel/atlas.h5" "${render_args[@]}" -o "$rel/render.exr"
trap - ERR
rm -rf "$backup"
ls -l "${files[@]/#/$rel/}"
echo "regenerate.sh: golden files written to $rel/ ($(du -ch "${files[@]/#/$rel/}" | tail -1 | cut -f1) in all)"
