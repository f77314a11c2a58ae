#!/usr/bin/env bash
# Every relative link in README.md, the Markdown files under docs/ and the scenes' READMEs resolves:
# Markdown links and images ](target) relative to the file, and paths written out as docs/... relative to
# the repository root. History left the tree (git keeps it); a link into it would be a dead end.
set -euo pipefail
cd "$(dirname "$0")/../.."
bad=0
while read -r md; do
  dir=$(dirname "$md")
  while read -r target; do
    target=${target%%#*}
    [[ -z $target || $target =~ ^[a-z]+: ]] && continue
    [[ -e $dir/$target ]] || { echo "$md: broken link ($target)" >&2; bad=1; }
  done < <(grep -oE '\]\([^) ]+\)' "$md" | sed -E 's/^\]\((.*)\)$/\1/')
  while read -r path; do
    path=${path%.}
    [[ -e $path ]] || { echo "$md: names $path, which does not exist" >&2; bad=1; }
  done < <(grep -oE '(^|[^A-Za-z0-9_./:-])docs/[A-Za-z0-9_./-]+\.(md|png|svg)' "$md" | sed -E 's/^[^d]//')
done < <(ls README.md scenes/*/README.md; find docs -name '*.md' | sort)
(( bad == 0 )) && echo "check-links: every link resolves"
exit $bad
