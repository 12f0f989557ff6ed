#!/usr/bin/env bash
# Installs every build, test and benchmark dependency of Loam from Debian's packages.
# Idempotent: when every package is already installed it does nothing (no apt-get update).
# `setup.sh --build` installs only what building needs (the container image's build stage).
set -euo pipefail

# What building Loam needs (the container image's build stage installs only these: --build).
BUILD_PACKAGES=(
  # toolchain
  cmake ninja-build ccache g++ pkg-config
  # libraries
  libasio-dev libglfw3-dev libglm-dev libzstd-dev libopenexr-dev libgdal-dev
  libegl-dev libegl-mesa0 libgl1-mesa-dri libgl-dev libepoxy-dev
  libgtest-dev libgmock-dev libcli11-dev libxxhash-dev libimgui-dev liblerc-dev nlohmann-json3-dev
  libssl-dev
)
# What testing, fuzzing and benchmarking need besides.
TEST_PACKAGES=(
  clang libclang-rt-14-dev clang-format
  # loam-bench's codec suite measures OpenImageIO's PNG writer; idiff compares golden images
  libopenimageio-dev openimageio-tools
  xvfb xauth gnuplot-nox gdal-bin
  # deploy/ checks: the systemd unit (systemd-analyze) and the manifests (YAML)
  systemd python3-yaml
)

PACKAGES=("${BUILD_PACKAGES[@]}")
if [ "${1:-}" != "--build" ]; then PACKAGES+=("${TEST_PACKAGES[@]}"); fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "setup: done"
