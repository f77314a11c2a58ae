#!/usr/bin/env bash
# The README's test command: installs dependencies (if root), builds in Release, runs the whole test
# suite, then builds with AddressSanitizer + UndefinedBehaviorSanitizer and runs the unit tier under them.
#   scripts/test.sh              everything (what CI runs)
#   scripts/test.sh unit         one tier only (unit | statistical | pipeline | stress | mutant), Release build only
# The full run includes the mutant tier (tests/mutants: injected bugs that the tests must catch).
#   IRIS_SANITIZE_ALL=1 scripts/test.sh     the whole suite under the sanitizers too (docs/ROBUSTNESS.md)
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ $(id -u) -eq 0 && -z "${IRIS_SKIP_INSTALL:-}" ]]; then bash scripts/install-deps.sh; fi
jobs=$(nproc)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$jobs"
if [[ $# -gt 0 ]]; then
  ctest --test-dir build --output-on-failure -j"$jobs" -L "$1"
  exit
fi
ctest --test-dir build --output-on-failure -j"$jobs"

# Sanitizers: memory errors and undefined behaviour abort the test that hits them.
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DIRIS_SANITIZE=ON >/dev/null
if [[ -n "${IRIS_SANITIZE_ALL:-}" ]]; then
  cmake --build build-asan -j"$jobs"
  ctest --test-dir build-asan --output-on-failure -j"$jobs"
else
  cmake --build build-asan -j"$jobs" --target unit_tests
  ctest --test-dir build-asan --output-on-failure -j"$jobs" -L unit
fi
