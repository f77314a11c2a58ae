#!/usr/bin/env bash
# The main job: install dependencies (when run as root), build the tools it runs (Release; the tests are built
# by scripts/test.sh), and run the full guided pipeline on the default scene (glass spheres in a Cornell box):
# photons -> caches -> atlas -> guided render, the unguided render at the same total time, a reference, and
# their comparison (out/glass_spheres/comparison.txt).
#
# At 256 x 256 (the scene's film is 512 x 512): the unguided reference of 1024 spp is most of the job's time
# (at full size it alone took 8.5 min on the shared 2 cores); at this size it costs a quarter, and its own noise
# (relMSE ~0.016) stays below the guided render's error (README.md, "Main job").
# Extra arguments go to make and override these, e.g.:
#   scripts/main-job.sh RESOLUTION= REF_SPP=4096 TIME=60 SCENE=scenes/thesis/veach_bidir/bidir.xml
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ $(id -u) -eq 0 && -z "${IRIS_SKIP_INSTALL:-}" ]]; then bash scripts/install-deps.sh; fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)" --target trace-photons place-caches fill-caches render compare-images
make -f pipelines/guided.mk compare RESOLUTION=256x256 REF_SPP=1024 TIME=30 "$@"
