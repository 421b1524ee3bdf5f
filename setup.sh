#!/usr/bin/env bash
# Installs every dependency of facecap from Debian 12 packages, builds, and runs what is asked.
# Idempotent; runs as root or through sudo (it calls sudo for apt-get when not root).
#
#   ./setup.sh            install the Debian packages and build (build/facecap)
#   ./setup.sh demo       ... then run the demo pipeline and print its metrics
#   ./setup.sh test       ... then run the whole test suite (ctest, without the "long" label)
#                         and the fuzz targets for 20 s each (tests/fuzz/run.sh)
#   ./setup.sh test-long  ... then run the whole suite including long tests
set -euo pipefail
cd "$(dirname "$0")"
MODE="${1:-build}"
case "$MODE" in
  build|demo|test|test-long) ;;
  *) echo "usage: ./setup.sh [build|demo|test|test-long]" >&2; exit 2 ;;
esac

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  # parallelism and numerics
  openmpi-bin libopenmpi-dev libeigen3-dev
  # the BLAS under libtorch's linear layers (preferred over ATLAS or the reference BLAS through
  # Debian's alternatives); its OpenMP build follows each rank's thread count
  libopenblas0-openmp
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
  # real test media: a portrait photo (grace_hopper.jpg) for the face and ingest tests
  python-matplotlib-data
  # lip-sync: espeak-ng speaks texts with phone timings for talking clips (the library and its
  # voices); pocketsphinx recognizes phones in a video's sound (the library and its US English
  # model)
  espeak-ng libespeak-ng-dev libpocketsphinx-dev pocketsphinx-en-us
  # the fuzzing build (tests/fuzz, run by `./setup.sh test`): clang with libFuzzer, ASan and
  # UBSan; their runtimes (libclang-rt-14-dev) and clang's OpenMP (libomp-dev) are only
  # recommended by clang, so they are listed
  clang libfuzzer-14-dev libclang-rt-14-dev libomp-dev
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

# ---- build --------------------------------------------------------------------------------
JOBS="${FACECAP_BUILD_JOBS:-$(nproc)}"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$JOBS"

# OpenMPI refuses to start as root without these; containers and CI often run as root.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none

case "$MODE" in
  demo)
    # The demo pipeline on 2 ranks; rerunning skips what is up to date.
    mpirun --oversubscribe -n 2 ./build/facecap run jobs/demo.toml
    echo "setup.sh: demo outputs in out/demo/"
    ;;
  test)
    ctest --test-dir build --output-on-failure -j 2 -LE long
    # The file readers under libFuzzer with ASan and UBSan (build-fuzz/), 20 s per target.
    FACECAP_BUILD_JOBS="$JOBS" tests/fuzz/run.sh 20
    ;;
  test-long)
    ctest --test-dir build --output-on-failure -j 2
    ;;
esac
