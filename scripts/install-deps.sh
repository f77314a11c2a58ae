#!/usr/bin/env bash
# Installs everything iris needs to build and test, from Debian packages (python3-matplotlib: the
# benchmark harness's plots, scripts/bench/; python3-numpy: scripts/exr.py and the harness). Run as root
# (or with sudo).
set -euo pipefail
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  build-essential cmake make pkg-config \
  libembree-dev libopenexr-dev libimath-dev libhdf5-dev hdf5-tools libcli11-dev libtinyobjloader-dev \
  slurm-wlm munge bc \
  libtbb-dev libnanoflann-dev libpugixml-dev libgtest-dev libpng-dev libjpeg-dev libstb-dev zlib1g-dev \
  python3 python3-matplotlib python3-numpy >/dev/null
echo "install-deps: done"
