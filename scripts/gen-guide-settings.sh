#!/usr/bin/env bash
# Writes the settings section of docs/GUIDE.md from the four stage tools' own tables, so that the guide
# cannot drift from them: the text between the two marker lines below is replaced by what
# `trace-photons`, `place-caches`, `fill-caches` and `render --list-settings` print (one Markdown table each).
#
#   scripts/gen-guide-settings.sh [BIN]           rewrite the section (BIN: the tools' folder, default build/bin)
#   scripts/gen-guide-settings.sh --check [BIN]   exit 1, with a diff, where GUIDE.md differs (a ctest)
set -euo pipefail
cd "$(dirname "$0")/.."
check=0
if [[ ${1:-} == --check ]]; then check=1; shift; fi
bin=${1:-build/bin}
guide=docs/GUIDE.md
begin='<!-- settings:begin'
end='<!-- settings:end -->'
header='| setting | stage | type | default | unit | meaning |'

fail() { echo "gen-guide-settings: error: $*" >&2; exit 1; }
[[ $(grep -c "^$begin" "$guide") == 1 && $(grep -c "^$end" "$guide") == 1 ]] ||
  fail "$guide: needs exactly one line starting '$begin' and one '$end'"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
section=$tmp/section.md
: > "$section"
for tool in trace-photons place-caches fill-caches render; do
  [[ -x $bin/$tool ]] || fail "$bin/$tool: not found (build the tools first)"
  "$bin/$tool" --list-settings > "$tmp/$tool.md" 2> "$tmp/$tool.err" ||
    fail "$bin/$tool --list-settings failed: $(head -n 1 "$tmp/$tool.err")"
  [[ $(head -n 1 "$tmp/$tool.md") == "$header" ]] ||
    fail "$bin/$tool --list-settings: the first line is not the header '$header'"
  printf '\n#### `%s`\n\n' "$tool" >> "$section"
  cat "$tmp/$tool.md" >> "$section"
done
echo >> "$section"

# The marker lines stay; everything between them is the section.
awk -v begin="$begin" -v end="$end" -v section="$section" '
  index($0, begin) == 1 { print; while ((getline line < section) > 0) print line; skip = 1; next }
  index($0, end) == 1   { skip = 0 }
  !skip                 { print }' "$guide" > "$tmp/GUIDE.md"

if (( check )); then
  if ! cmp -s "$guide" "$tmp/GUIDE.md"; then
    diff -u "$guide" "$tmp/GUIDE.md" | head -n 60 >&2 || true
    fail "$guide: the settings section differs from the tools' --list-settings; run scripts/gen-guide-settings.sh"
  fi
  echo "gen-guide-settings: $guide matches the tools' --list-settings"
else
  cp "$tmp/GUIDE.md" "$guide"
fi
