#!/usr/bin/env bash
# Installs dependencies (if root), builds in Release, and runs the whole test suite.
# Tiers: `ctest -L unit` (seconds), `-L statistical`, `-L pipeline`. Pass a label to run one tier:
#   scripts/test.sh unit
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ $(id -u) -eq 0 && -z "${IRIS_SKIP_INSTALL:-}" ]]; then bash scripts/install-deps.sh; fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
label=()
if [[ $# -gt 0 ]]; then label=(-L "$1"); fi
ctest --test-dir build --output-on-failure -j"$(nproc)" "${label[@]}"
