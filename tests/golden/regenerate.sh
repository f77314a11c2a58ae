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
# Guards: it refuses to run while the repository has uncommitted changes (`git status --porcelain` not
# empty: the files must come from a commit, and the tools in BIN_DIR must be built from that commit);
# it records that commit in PROVENANCE; before replacing anything it prints, for every file, the
# statistics of the previous golden file and of the new one (inspect-caches for the stage files,
# compare-images for the render: relMSE, channel means) as a diff; on any failure the previous files
# are kept.
#
# Usage: tests/golden/regenerate.sh [BIN_DIR]    (default: $IRIS_BIN_DIR, else build/bin)
# Also: make -C tests/golden [BIN=...]
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
if [[ -n "$(git status --porcelain)" ]]; then
  echo "regenerate.sh: error: the repository has uncommitted changes (git status --porcelain); commit first, so that PROVENANCE names the commit the golden files come from" >&2
  exit 1
fi
commit="$(git rev-parse HEAD)"
scene="$(args scene)"
rel="tests/golden"
files=(photons.h5 caches.h5 atlas.h5 render.exr)
# The stages write into a scratch folder; the previous golden files are replaced only once every stage
# has succeeded, so the folder never holds outputs of two different runs.
new="$(mktemp -d)"
trap 'echo "regenerate.sh: error: a stage failed; the previous golden files are kept" >&2; rm -rf "$new"' ERR
# A fixed creation time, for fewer spurious differences (the stages still record their run time).
export SOURCE_DATE_EPOCH=0
read -ra trace_args <<<"$(args trace-photons)"
read -ra place_args <<<"$(args place-caches)"
read -ra fill_args <<<"$(args fill-caches)"
read -ra render_args <<<"$(args render)"
# (The command lines recorded in the files name the scratch folder for the previous stage's output.)
"$bin/trace-photons" "$scene" -q "${trace_args[@]}" -o "$new/photons.h5"
"$bin/place-caches" "$scene" -q --photon-map "$new/photons.h5" "${place_args[@]}" -o "$new/caches.h5"
"$bin/fill-caches" "$new/caches.h5" -q --photon-map "$new/photons.h5" "${fill_args[@]}" -o "$new/atlas.h5"
"$bin/render" "$scene" -q --atlas "$new/atlas.h5" "${render_args[@]}" -o "$new/render.exr"
# The statistics of every file, previous against new (lines starting - are the previous file's).
for f in photons.h5 caches.h5 atlas.h5; do
  echo "=== $f: statistics, previous (-) and new (+)"
  if [[ -e "$rel/$f" ]]; then
    diff -u --label "previous $f" --label "new $f" <("$bin/inspect-caches" "$rel/$f" | grep -v '^command line') \
      <("$bin/inspect-caches" "$new/$f" | grep -v '^command line') || true
  else
    "$bin/inspect-caches" "$new/$f"
  fi
done
echo "=== render.exr: new against previous (compare-images NEW PREVIOUS)"
if [[ -e "$rel/render.exr" ]]; then "$bin/compare-images" "$new/render.exr" "$rel/render.exr" || true; fi
{
  echo "# Made by tests/golden/regenerate.sh; test_golden_stages.cpp needs the tools of this commit (or of"
  echo "# code that computes the same) to reproduce the files to float tolerance."
  echo "commit $commit"
  echo "tools $("$bin/render" --version | head -1)"
  cc="$(sed -n "s/^CMAKE_CXX_COMPILER:[A-Z]*=//p" "$bin/../CMakeCache.txt" 2>/dev/null | head -1 || true)"; [[ -z "$cc" ]] || echo "compiler $cc"
} >"$new/PROVENANCE"
for f in "${files[@]}" PROVENANCE; do mv "$new/$f" "$rel/$f"; done
trap - ERR
rm -rf "$new"
ls -l "${files[@]/#/$rel/}"
echo "regenerate.sh: golden files written to $rel/ from commit $commit ($(du -ch "${files[@]/#/$rel/}" | tail -1 | cut -f1) in all)"
