# Sourced by the analysis scripts: strict mode, where the source and the build are, the
# facecap binary, mpirun for local runs, and a helper that builds a target first.
#
#   source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
#
# The build directory is the script's first argument when it is not an option ("--" ends
# them), else $FACECAP_BUILD_DIR, else build/ under the source tree; the consumed argument
# is shifted away by `take_build_dir "$@"; set -- "${rest[@]}"`.
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
rest=()

# Takes BUILD_DIR (and a following "--") off the arguments; the others go to ${rest[@]}.
take_build_dir() {
  rest=("$@")
  if [[ ${#rest[@]} -gt 0 && "${rest[0]}" != "--" && "${rest[0]}" != -* ]]; then
    build_dir="${rest[0]}"
    rest=("${rest[@]:1}")
  fi
  if [[ ${#rest[@]} -gt 0 && "${rest[0]}" == "--" ]]; then rest=("${rest[@]:1}"); fi
  # Absolute, so that it holds after a script changes folder.
  if [[ -d "${build_dir}" ]]; then build_dir="$(cd "${build_dir}" && pwd)"; fi
  facecap="${build_dir}/facecap"
}
facecap="${build_dir}/facecap"

# Builds the named targets when build_dir is a configured build; fails with the build's last
# lines otherwise.
build_targets() {
  [[ -f "${build_dir}/build.ninja" || -f "${build_dir}/Makefile" ]] || return 0
  local log
  log="$(mktemp)"
  if ! cmake --build "${build_dir}" --target "$@" >"${log}" 2>&1; then
    tail -n 40 "${log}" >&2
    echo "error: building $* in ${build_dir} failed" >&2
    rm -f "${log}"
    exit 1
  fi
  rm -f "${log}"
}

# Fails unless the facecap binary exists.
require_facecap() {
  [[ -x "${facecap}" ]] || { echo "error: ${facecap} not built; configure and build first (cmake -S . -B build -G Ninja)" >&2; exit 1; }
}

# Local MPI runs (also as root in containers, without the single-copy mechanism that
# containers often forbid).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism="${OMPI_MCA_btl_vader_single_copy_mechanism:-none}"
mpirun_cmd=(mpirun --oversubscribe)
