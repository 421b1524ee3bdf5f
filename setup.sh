#!/usr/bin/env bash
# Installs every dependency of facecap from Debian 12 packages. Idempotent; runs as root
# or through sudo. Usage: ./setup.sh
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  # parallelism and numerics
  openmpi-bin libopenmpi-dev libeigen3-dev
  # data, images, video, meshes
  libhdf5-openmpi-dev hdf5-tools libopenimageio-dev openimageio-tools
  libopencv-dev ffmpeg libassimp-dev
  # solvers, networks, landmarks
  libceres-dev libtorch-dev libdlib-dev libdlib-data libnanoflann-dev
  # command line, configuration, logging, tests
  libcli11-dev libtomlplusplus-dev libspdlog-dev libgtest-dev libgmock-dev
  # Slurm for the batch scripts and their tests
  slurm-wlm munge
  # analysis scripts (Debian's python3)
  python3-h5py python3-matplotlib python3-numpy
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup.sh: run as root or install sudo" >&2; exit 1; }
  SUDO="sudo"
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup.sh: installing ${#missing[@]} Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "setup.sh: all ${#PACKAGES[@]} Debian packages present"
fi
