#!/usr/bin/env bash
# Segmentation renders per second per core at 128x128 (target: >= 500), measured
# on one thread, with the other rasterizer outputs for reference.
#
#   analysis/bench_render.sh [BUILD_DIR] [-- extra facecap_bench_render options]
#
# BUILD_DIR defaults to $FACECAP_BUILD_DIR, then build/ under the source tree. Extra
# options go to the benchmark, e.g. `-- --rig rig.h5` for another head, `-- --size 256`.
# Without --rig, the demo head (`facecap rig demo`) is measured, and an icosphere of similar
# size for reference.
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
set -- ${rest[@]+"${rest[@]}"}

build_targets facecap_bench_render
bench="${build_dir}/facecap_bench_render"
if [[ ! -x "${bench}" ]]; then
  echo "error: ${bench} not found; configure and build first (cmake -S . -B build -G Ninja)" >&2
  exit 1
fi

echo "# facecap render benchmark, 1 thread ($(uname -m), $(getconf _NPROCESSORS_ONLN) cores on this machine)"
if [[ " $* " == *" --rig "* ]]; then
  OMP_NUM_THREADS=1 "${bench}" --size 128 "$@"
else
  tmp_dir="$(mktemp -d)"
  trap 'rm -rf "${tmp_dir}" "${build_log:-}"' EXIT
  "${build_dir}/facecap" rig demo --out "${tmp_dir}/rig.h5" >/dev/null 2>&1
  echo "## demo head"
  OMP_NUM_THREADS=1 "${bench}" --size 128 --rig "${tmp_dir}/rig.h5" "$@"
  echo "## icosphere (reference)"
  OMP_NUM_THREADS=1 "${bench}" --size 128 "$@"
fi
