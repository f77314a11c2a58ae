#!/usr/bin/env bash
# Runs the walkthrough of docs/GUIDE.md literally, as a user would type it: the fenced blocks tagged
# ```sh walkthrough, in order, each with bash -e in one temporary folder that looks like the repository root
# (build/bin -> the tools under test, scenes/ and pipelines/ -> the source tree's). Checks that every command
# succeeds, that every file a command writes (-o FILE) exists and is not empty, and that the blocks after the
# first (a changed render setting reusing the atlas) leave every file made before them untouched (same
# modification time, to the nanosecond): re-rendering must not re-run a stage.
#   tests/docs/run-walkthrough.sh BIN     (BIN: the folder of the built tools; ctest passes build/bin)
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
bin=$(cd "${1:?usage: run-walkthrough.sh BIN}" && pwd)
guide=$src/docs/GUIDE.md
fail() { echo "run-walkthrough: error: $*" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/build" "$work/.blocks"
ln -s "$bin" "$work/build/bin"
ln -s "$src/scenes" "$work/scenes"
ln -s "$src/pipelines" "$work/pipelines"

awk -v dir="$work/.blocks" '
  /^```sh walkthrough[[:space:]]*$/ { n++; file = sprintf("%s/%02d.sh", dir, n); inside = 1; printf "" > file; next }
  inside && /^```[[:space:]]*$/     { inside = 0; close(file); next }
  inside                            { print > file }' "$guide"
blocks=("$work"/.blocks/*.sh)
[[ -e ${blocks[0]} && ${#blocks[@]} -ge 2 ]] ||
  fail "$guide: needs at least two \`\`\`sh walkthrough blocks (the stages, then a re-render), found ${#blocks[@]}"

# Every file under the folder (the blocks themselves aside) with its modification time in nanoseconds.
snapshot() { (cd "$work" && find . -path ./.blocks -prune -o -type f -printf '%p %T@\n' | sort); }

reused_atlas=0
for i in "${!blocks[@]}"; do
  block=${blocks[$i]}
  echo "== walkthrough block $((i + 1)):"
  sed 's/^/   /' "$block"
  before=$(snapshot)
  if (( i > 0 )); then
    # A later block must reuse a file made before it as --atlas.
    while read -r atlas; do
      [[ -f $work/$atlas ]] && reused_atlas=1
    done < <(grep -oE -- '--atlas[ =][^ ]+' "$block" | sed -E 's/--atlas[ =]//')
  fi
  (cd "$work" && bash -euo pipefail "$block") || fail "block $((i + 1)) failed (the commands above)"
  while read -r out; do
    [[ -s $work/$out ]] || fail "block $((i + 1)): $out (written with -o) is missing or empty"
  done < <(grep -oE -- '(^| )(-o|--output) [^ ]+' "$block" | awk '{print $2}')
  if (( i > 0 )); then
    after=$(snapshot)
    changed=$(comm -23 <(echo "$before") <(echo "$after") | grep -v '^$' || true)
    [[ -z $changed ]] || fail "block $((i + 1)) changed or removed files made before it: $(echo "$changed" | tr '\n' ' ')"
  fi
done
(( reused_atlas )) || fail "no block after the first renders with --atlas of a file made before it"
echo "run-walkthrough: ${#blocks[@]} blocks ran; the later ones reused the atlas and left the stage files untouched"
