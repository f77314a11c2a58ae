#!/usr/bin/env bash
# One test of the mutant tier (tests/mutants/README.md): runs one GoogleTest filter of a test binary
# with IRIS_MUTANT=MUTANT and succeeds only when the mutant announced itself ("iris: mutant MUTANT
# active") and the tests failed by an assertion (gtest's "[  FAILED  ]" line, exit status 1). A crash,
# a timeout (ctest's TIMEOUT), an inactive or misspelt mutant, or tests that pass all make it fail.
#   run-mutant.sh MUTANT TEST_BINARY GTEST_FILTER
set -uo pipefail
mutant="$1" binary="$2" filter="$3"
unset IRIS_MUTANT_ANNOUNCED
out="$(IRIS_MUTANT="$mutant" "$binary" --gtest_filter="$filter" 2>&1)"
rc=$?
fail() { printf '%s\n' "$out" | tail -40; echo "mutant $mutant, $filter: $1" >&2; exit 1; }
grep -qx "iris: mutant $mutant active" <<<"$out" || fail "the mutant did not announce itself"
[[ $rc -eq 0 ]] && fail "NOT CAUGHT: the tests passed with the mutant active"
[[ $rc -ne 1 ]] && fail "the test binary ended with status $rc (a crash or a signal), not by a failed assertion"
grep -q '^\[  FAILED  \]' <<<"$out" || fail "no failed assertion in the output"
grep -q '^\[==========\] 0 tests' <<<"$out" && fail "the filter matched no test"
printf '%s\n' "$out" | grep -E '^\[  FAILED  \]|^iris: mutant' | sort -u
echo "mutant $mutant caught by $filter"
