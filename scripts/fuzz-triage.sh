#!/usr/bin/env bash
# Groups the inputs scripts/fuzz.sh saved in build-fuzz/crashes/<target>/ by what they trigger.
#
#   bash scripts/fuzz-triage.sh TARGET
#
# Replays each file with build-fuzz/bin/fuzz_<TARGET> and prints one line per distinct signature:
# the count, the error (ASan/UBSan/uncaught exception/timeout), the top stack frame and the innermost
# frame in iris's own code (formats/, libcommon/, tests/fuzz/), and one example file. A signature whose
# top frame is in a system library (e.g. libhdf5_serial.so) with iris's frame only the API call is a
# crash inside that library; one whose top frame is in iris is ours to fix. Full reports go to
# build-fuzz/triage/<TARGET>/<file>.txt.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
T=${1:?usage: fuzz-triage.sh TARGET}
BIN="$ROOT/build-fuzz/bin/fuzz_$T"
DIR="$ROOT/build-fuzz/crashes/$T"
OUT="$ROOT/build-fuzz/triage/$T"
mkdir -p "$OUT"
shopt -s nullglob
for f in "$DIR"/*; do
  rep="$OUT/$(basename "$f").txt"
  [[ -s $rep ]] || ASAN_OPTIONS=fast_unwind_on_malloc=0 nice -n 15 "$BIN" -timeout="${FUZZ_TIMEOUT:-25}" -rss_limit_mb=2048 "$f" >"$rep" 2>&1 || true
  err=$(grep -m1 -oE 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer): [A-Za-z-]+( on unknown address)?|runtime error: [^:]*|terminate called after throwing an instance of .*|ALARM: working on the last Unit for [0-9]+|out-of-memory' "$rep" || echo "no error reproduced")
  top=$(grep -m1 -E '^ +#0 ' "$rep" | sed -E 's/^ +#0 0x[0-9a-f]+ in //; s/\(.*BuildId.*//; s/ \/work\/main\// /' | cut -c1-90 || true)
  ours=$(grep -E '^ +#[0-9]+ ' "$rep" | grep -m1 -E '/work/main/(formats|libcommon|tests/fuzz)/' |
    sed -E 's/\(anonymous namespace\)/{anon}/g; s/^ +#[0-9]+ 0x[0-9a-f]+ in ([^(]+)\(.* \/work\/main\/([^ ]+).*/\1 \2/' |
    cut -c1-110 || true)
  printf '%s\t%s\t%s\t%s\n' "$err" "${top:-?}" "${ours:-?}" "$(basename "$f")"
done | sort | awk -F'\t' '{ key = $1 FS $2 FS $3; n[key]++; if (!(key in ex)) ex[key] = $4 }
  END { for (k in n) { split(k, a, FS); printf "%4d  %s\n      top: %s\n      iris: %s\n      e.g. %s\n", n[k], a[1], a[2], a[3], ex[k] } }'
