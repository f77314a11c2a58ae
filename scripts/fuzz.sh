#!/usr/bin/env bash
# Fuzzes iris's file readers with libFuzzer (clang from Debian), ASan and UBSan.
#
#   bash scripts/fuzz.sh [CPU_SECONDS] [TARGET...]
#
# CPU_SECONDS (default 1800) is the CPU time (user + sys, measured) each target gets: a target runs in
# rounds of libFuzzer -max_total_time=<CPU seconds still owed> until its measured CPU time reaches
# CPU_SECONDS, so a busy or shared machine gets the same amount of fuzzing, only later. TARGETs are
# scene_xml (load_scene on a scene XML), obj (parse_obj), mesh (parse_ply, parse_serialized) and hdf5
# (the stage-file readers); default all four, one after another (FUZZ_PARALLEL=2 runs two at a time).
#
# Installs clang and libFuzzer with apt-get if missing (as root, or through sudo), configures and builds
# build-fuzz/ (IRIS_FUZZ=ON), and keeps, per target:
#   build-fuzz/corpus/<target>/    the growing corpus (reused by later runs)
#   build-fuzz/seeds/<target>/     seeds, rebuilt each run from the repository's scenes, meshes,
#                                  golden stage files and tests/fuzz/seeds/<target>/
#   build-fuzz/crashes/<target>/   crash-*, leak-*, timeout-*, oom-* inputs libFuzzer found
#   build-fuzz/logs/<target>-<run>-<round>.log, and build-fuzz/logs/<target>.summary (appended to)
# A found crash ends that target's run, except for FUZZ_KEEP_GOING targets; the exit status is 1 when
# any target's crashes/ folder holds a file. Reproduce one with
#   build-fuzz/bin/fuzz_<target> FILE;  minimise with  ... -minimize_crash=1 -runs=20000 FILE
# and keep it under tests/data/fuzz-regressions/<target>/ (tests/unit/test_fuzz_regressions.cpp runs
# every file there through the same harness in the ordinary test build).
#
# Environment: FUZZ_PARALLEL (targets at once, default 1), FUZZ_BUILD_JOBS (default 2), FUZZ_NICE
# (niceness of the fuzzers, default 15), FUZZ_TIMEOUT (seconds one input may take; default 5 for
# hdf5, whose damaged files make libhdf5 loop for ever now and then, 25 for the others),
# FUZZ_KEEP_GOING (targets fuzzed in fork mode that go on after a crash, default "hdf5"), FUZZ_FORK_JOBS
# (parallel jobs of such a target, default 1: count them against FUZZ_PARALLEL),
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CPU_SECONDS=${1:-1800}
shift || true
TARGETS=("$@")
[[ ${#TARGETS[@]} -gt 0 ]] || TARGETS=(scene_xml obj mesh hdf5)
BUILD="$ROOT/build-fuzz"
PARALLEL=${FUZZ_PARALLEL:-1}
NICE=${FUZZ_NICE:-15}
TIMEOUT=${FUZZ_TIMEOUT:-}
RUN_ID=$(date -u +%Y%m%dT%H%M%SZ)
KEEP_GOING=${FUZZ_KEEP_GOING-hdf5}

for t in "${TARGETS[@]}"; do
  case $t in scene_xml | obj | mesh | hdf5) ;; *) echo "fuzz.sh: unknown target '$t' (scene_xml, obj, mesh, hdf5)" >&2; exit 2 ;; esac
done

# ---- clang + libFuzzer -------------------------------------------------------------------------------
have_libfuzzer() {
  command -v clang++ >/dev/null && [[ -x /usr/bin/time ]] &&
    echo 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char*, unsigned long) { return 0; }' |
    clang++ -x c++ -fsanitize=fuzzer,address,undefined -o /dev/null - 2>/dev/null
}
if ! have_libfuzzer; then
  echo "fuzz.sh: installing clang and libFuzzer (apt-get)"
  SUDO=""
  [[ $(id -u) -eq 0 ]] || SUDO=sudo
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends clang libclang-rt-dev time >/dev/null
  have_libfuzzer || { echo "fuzz.sh: clang++ -fsanitize=fuzzer does not work" >&2; exit 1; }
fi

# ---- build -----------------------------------------------------------------------------------------
nice -n 5 cmake -S "$ROOT" -B "$BUILD" -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DIRIS_FUZZ=ON >/dev/null
nice -n 5 cmake --build "$BUILD" -j "${FUZZ_BUILD_JOBS:-2}" --target "${TARGETS[@]/#/fuzz_}"

# ---- seeds -----------------------------------------------------------------------------------------
# Scene files name their meshes relative to their own folder; the harness runs every input in a scratch
# folder holding mesh.obj and tri.obj (tests/fuzz/harness.h), so the seeds' mesh references are
# rewritten to those two names, alternately, to let the seeds get past the meshes.
seed_scene_xml() {
  local out=$1 i=0 f
  while IFS= read -r -d '' f; do
    i=$((i + 1))
    perl -pe 's/value="[^"]*\.obj"/"value=\"" . ($n++ % 2 ? "tri.obj" : "mesh.obj") . "\""/ge' \
      "$f" >"$out/$i-$(basename "$f")"
  done < <(find "$ROOT/scenes" "$ROOT/tests/data" -name '*.xml' -not -path '*/fuzz-regressions/*' -print0 2>/dev/null | sort -z)
}
seed_obj() {
  local out=$1 i=0 f
  while IFS= read -r -d '' f; do
    i=$((i + 1))
    cp "$f" "$out/$i-$(basename "$f")"
  done < <(find "$ROOT/scenes" "$ROOT/tests/data" -name '*.obj' -size -64k -not -path '*/fuzz-regressions/*' -print0 2>/dev/null | sort -z)
}
# hdf5: byte 0 of an input picks the reader (harness.h); each golden file goes to its own readers
# (0/1 photons, 2/3 caches, 4/5 atlas) and to the generic ones (6 read_stage_header, 7 stage_file_format).
seed_hdf5() {
  local out=$1 f sel
  for f in "$ROOT"/tests/golden/*.h5; do
    case $(basename "$f") in photons.h5) sel="0 1" ;; caches.h5) sel="2 3" ;; atlas.h5) sel="4 5" ;; *) sel="" ;; esac
    for s in $sel 6 7; do
      { printf "\\x0$s"; cat "$f"; } >"$out/$s-$(basename "$f")"
    done
  done
}

# PLY and serialized meshes: the committed seeds (tests/fuzz/seeds/mesh/, from tests/fuzz/make_mesh_seeds.py)
# are all; fuzz_target copies them in.
seed_mesh() { :; }

# ---- fuzzing ---------------------------------------------------------------------------------------
fuzz_target() {
  local t=$1 corpus="$BUILD/corpus/$1" seeds="$BUILD/seeds/$1" crashes="$BUILD/crashes/$1"
  local summary="$BUILD/logs/$1.summary"
  rm -rf "$seeds"
  mkdir -p "$corpus" "$seeds" "$crashes" "$BUILD/logs"
  "seed_$t" "$seeds"
  [[ -d "$ROOT/tests/fuzz/seeds/$t" ]] && cp "$ROOT/tests/fuzz/seeds/$t"/* "$seeds"/ 2>/dev/null || true
  local timeout=$TIMEOUT
  [[ -n $timeout ]] || { [[ $t == hdf5 ]] && timeout=5 || timeout=25; }
  local args=(-timeout="$timeout" -print_final_stats=1 -artifact_prefix="$crashes/")
  case $t in
    scene_xml) args+=(-dict="$ROOT/tests/fuzz/scene_xml.dict" -max_len=16384) ;;
    obj) args+=(-dict="$ROOT/tests/fuzz/obj.dict" -max_len=16384) ;;
    mesh) args+=(-max_len=16384) ;;
    hdf5) args+=(-max_len=131072) ;;
  esac
  # Keep-going targets run in libFuzzer's fork mode, which saves every crashing input and goes on: the
  # HDF5 library (Debian's 1.10.8) itself crashes on many damaged files, within seconds of fuzzing,
  # and a stop at each of those would leave the stage-file readers unfuzzed. Triage the crash files
  # afterwards (scripts/fuzz-triage.sh) to tell crashes in iris from crashes inside libhdf5.
  if [[ " $KEEP_GOING " == *" $t "* ]]; then
    args+=(-fork="${FUZZ_FORK_JOBS:-1}" -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
  fi
  local cpu_ms=0 round=0 execs=0 status=0 rc
  echo "== run $RUN_ID: $CPU_SECONDS CPU seconds" >>"$summary"
  while ((cpu_ms < CPU_SECONDS * 1000)); do
    round=$((round + 1))
    local left=$(((CPU_SECONDS * 1000 - cpu_ms + 999) / 1000))
    ((left >= 60)) || left=60  # a shorter round would spend most of its time loading the corpus
    local log="$BUILD/logs/$t-$RUN_ID-$round.log" times="$BUILD/logs/$t-$RUN_ID-$round.time"
    rc=0
    /usr/bin/time -f '%U %S' -o "$times" nice -n "$NICE" "$BUILD/bin/fuzz_$t" "${args[@]}" \
      -max_total_time="$left" "$corpus" "$seeds" >"$log" 2>&1 || rc=$?
    local user sys
    read -r user sys < <(tail -n 1 "$times")
    cpu_ms=$((cpu_ms + $(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%d", (u + s) * 1000 }')))
    local last n
    last=$(grep -E '^#[0-9]+' "$log" | tail -n 1 || true)
    # Executions: the final stats, or in fork mode (no final stats) the count on the last status line.
    n=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    [[ -n $n ]] || n=$(sed -E -n 's/^#([0-9]+).*/\1/p' <<<"$last")
    execs=$((execs + ${n:-0}))
    printf '%s round %d: rc %d, CPU %s s user + %s s sys; %s\n' "$t" "$round" "$rc" "$user" "$sys" "$last" | tee -a "$summary"
    # In fork mode (keep-going targets) the exit status is that of the last crashing job: go on.
    if ((rc != 0)) && [[ " $KEEP_GOING " != *" $t "* ]]; then
      status=1
      echo "$t: libFuzzer stopped with a finding (log: $log):" | tee -a "$summary"
      grep -E '^(==[0-9]+==ERROR|SUMMARY|.*runtime error|.*deadly signal|.*Test unit written)' "$log" | head -n 8 | tee -a "$summary"
      break
    fi
  done
  local found
  found=$(find "$crashes" -type f | wc -l)
  if ((found > 0)); then
    status=1
    echo "$t: $found crash/leak/timeout/oom inputs in $crashes" | tee -a "$summary"
  fi
  printf '%s: %d rounds, CPU %d.%03d s (%.1f min), %d executions, corpus %d files (%s)\n' "$t" "$round" \
    $((cpu_ms / 1000)) $((cpu_ms % 1000)) "$(awk -v m="$cpu_ms" 'BEGIN { print m / 60000 }')" "$execs" \
    "$(find "$corpus" -type f | wc -l)" "$(du -sh "$corpus" | cut -f1)" | tee -a "$summary"
  return $status
}

failed=0
running=0
for t in "${TARGETS[@]}"; do
  if ((PARALLEL > 1)); then
    if ((running >= PARALLEL)); then
      wait -n || failed=1
      running=$((running - 1))
    fi
    fuzz_target "$t" &
    running=$((running + 1))
  else
    fuzz_target "$t" || failed=1
  fi
done
while ((running > 0)); do
  wait -n || failed=1
  running=$((running - 1))
done
echo "fuzz.sh: summaries in $BUILD/logs/*.summary"
exit $failed
