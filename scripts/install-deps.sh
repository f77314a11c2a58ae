#!/usr/bin/env bash
# Installs everything iris needs to build and test, from Debian packages. Run as root (or with sudo).
set -euo pipefail
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  build-essential cmake make pkg-config \
  libembree-dev libopenexr-dev libimath-dev libhdf5-dev hdf5-tools libcli11-dev libtinyobjloader-dev \
  libtbb-dev libnanoflann-dev libpugixml-dev libgtest-dev libpng-dev zlib1g-dev >/dev/null
echo "install-deps: done"
