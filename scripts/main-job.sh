#!/usr/bin/env bash
# The main job: install dependencies (when run as root), build in Release, and run the full guided
# pipeline on the default scene (glass spheres in a Cornell box): photons -> caches -> atlas -> guided
# render, the unguided render at the same total time, a reference, and their comparison.
# Extra arguments go to make, e.g.: scripts/main-job.sh TIME=60 SCENE=scenes/thesis/veach_bidir/bidir.xml
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ $(id -u) -eq 0 && -z "${IRIS_SKIP_INSTALL:-}" ]]; then bash scripts/install-deps.sh; fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
make -f pipelines/guided.mk compare "$@"
