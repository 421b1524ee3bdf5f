#!/usr/bin/env bash
# Inverse-rendering solve time per frame per core at 128x128 with the demo head's 52
# controls (DESIGN.md target: <= 0.25 s) and parallel efficiency of `facecap track` on 2
# ranks against 1 (target: >= 90%), one thread per rank, the same frames.
#
#   analysis/bench_track.sh [BUILD_DIR] [-- extra facecap track options]
#
# Environment: FRAMES (default 16), SIZE (128), WORK (a temporary folder).
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
if [[ $# -gt 0 && "$1" != "--" ]]; then
  build_dir="$1"
  shift
fi
[[ $# -gt 0 && "$1" == "--" ]] && shift
facecap="${build_dir}/facecap"
[[ -x "${facecap}" ]] || { echo "error: ${facecap} not built" >&2; exit 1; }
frames="${FRAMES:-16}"
size="${SIZE:-128}"
work="${WORK:-$(mktemp -d)}"
mkdir -p "${work}"

"${facecap}" rig demo --out "${work}/rig.h5" >/dev/null 2>&1
"${facecap}" synth samples --rig "${work}/rig.h5" --count "${frames}" --size "${size}" \
  --out "${work}/samples.h5" >/dev/null 2>&1

wall() {  # prints the wall seconds of a track run on $1 ranks
  local ranks="$1" out="${work}/bench_$1.h5"
  shift
  rm -f "${out}" "${out}.partial"
  local start end
  start=$(date +%s.%N)
  OMP_NUM_THREADS=1 mpirun --oversubscribe --allow-run-as-root -n "${ranks}" "${facecap}" track \
    --rig "${work}/rig.h5" --targets "${work}/samples.h5" --out "${out}" --threads 1 \
    --batch 1 "$@" >/dev/null 2>&1 || { echo "error: facecap track failed" >&2; exit 1; }
  end=$(date +%s.%N)
  python3 -c "print(${end} - ${start})"
}

t1=$(wall 1 "$@")
t2=$(wall 2 "$@")
solve=$("${facecap}" eval track --truth "${work}/samples.h5" --track "${work}/bench_1.h5" \
  --rig "${work}/rig.h5" --json 2>/dev/null |
  python3 -c "import json, sys; print(json.load(sys.stdin)['sec_per_frame'])")
python3 - "${frames}" "${size}" "${t1}" "${t2}" "${solve}" <<'PY'
import sys
frames, size = int(sys.argv[1]), int(sys.argv[2])
t1, t2, solve = float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
print("track %dx%d, %d frames, 52 controls" % (size, size, frames))
print("  solve time per frame (1 core, from /track/seconds): %.3f s  (target <= 0.25)" % solve)
print("  wall per frame, 1 rank: %.3f s; 2 ranks: %.3f s" % (t1 / frames, t2 / frames))
print("  parallel efficiency 2 vs 1 ranks: %.1f%%  (target >= 90%%)" % (100 * t1 / (2 * t2)))
PY
