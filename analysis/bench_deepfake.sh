#!/usr/bin/env bash
# Data-parallel deepfake training: steps per second at the same global batch on 1 rank and on
# 2 ranks (one torch thread per rank), and the parallel efficiency (target: >= 85%
# at 2 ranks), with 1 rank x 2 threads beside it as the intra-op baseline.
#
#   analysis/bench_deepfake.sh [BUILD_DIR] [-- extra `deepfake train` flags]
#
# Environment: SIZE (default 64), BATCH (global batch, default 16), STEPS (default 60),
# REPEATS (default 3; the median counts), BASELINE (another build's facecap binary: its 2-rank
# rate is measured in the same repeats, interleaved, and the ratio of the two printed).
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
set -- ${rest[@]+"${rest[@]}"}
require_facecap
size="${SIZE:-64}"
batch="${BATCH:-16}"
steps="${STEPS:-60}"
if [[ -n "${BASELINE:-}" ]]; then
  [[ -x "${BASELINE}" ]] || { echo "error: BASELINE ${BASELINE} is not an executable" >&2; exit 1; }
  BASELINE="$(realpath "${BASELINE}")"  # the runs below change folder
fi
tmp_dir="$(mktemp -d)"
trap 'rm -rf "${tmp_dir}"' EXIT
cd "${tmp_dir}"
mpi() { mpirun --oversubscribe --allow-run-as-root -n "$1" "${@:2}"; }

"${facecap}" rig demo --out rig.h5 >/dev/null 2>&1
"${facecap}" synth samples --rig rig.h5 --count 256 --size "${size}" --out a.h5 >/dev/null 2>&1
"${facecap}" synth samples --rig rig.h5 --count 256 --size "${size}" --seed 2 --out b.h5 >/dev/null 2>&1

# Steps per second of the last progress line (the rate over the whole run, start-up excluded).
rate() {
  local ranks="$1" threads="$2" out="run_${1}x${2}_${BENCH_TAG:-}.h5"
  shift 2
  OMP_NUM_THREADS="${threads}" mpi "${ranks}" "${BENCH_BINARY:-${facecap}}" deepfake train \
    --a a.h5 --b b.h5 --size "${size}" --batch "${batch}" --steps "${steps}" --checkpoint-every 0 \
    --preview-every 0 --progress-seconds 1000 --out "${out}" "$@" 2>&1 \
    | grep -o '[0-9.]* steps/s' | tail -n 1 | cut -d' ' -f1
}

echo "# facecap deepfake training benchmark: ${size}x${size}, global batch ${batch}, ${steps} steps ($(uname -m), $(getconf _NPROCESSORS_ONLN) cores)"
# This machine's speed varies from minute to minute (shared host): each configuration runs
# REPEATS times, interleaved, and the median counts.
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
: > r1.txt; : > r2.txt; : > r12.txt; : > base.txt
for repeat in $(seq "${REPEATS:-3}"); do
  BENCH_TAG=${repeat} rate 1 1 "$@" >> r1.txt
  BENCH_TAG=${repeat} rate 2 1 "$@" >> r2.txt
  if [[ -n "${BASELINE:-}" ]]; then
    BENCH_TAG=b${repeat} BENCH_BINARY="${BASELINE}" rate 2 1 "$@" >> base.txt
  fi
  BENCH_TAG=${repeat} rate 1 2 "$@" >> r12.txt
done
echo "# steps/s per repeat: 1x1 $(paste -sd' ' r1.txt); 2x1 $(paste -sd' ' r2.txt); 1x2 $(paste -sd' ' r12.txt)"
r1="$(median < r1.txt)"
r2="$(median < r2.txt)"
r12="$(median < r12.txt)"
awk -v r1="${r1}" -v r2="${r2}" -v r12="${r12}" -v b="${batch}" 'BEGIN {
  printf "%-24s %10s %12s %10s\n", "configuration", "steps/s", "images/s", "speed-up";
  printf "%-24s %10.3f %12.1f %10.2f\n", "1 rank x 1 thread", r1, r1 * b * 2, 1;
  printf "%-24s %10.3f %12.1f %10.2f\n", "2 ranks x 1 thread", r2, r2 * b * 2, r2 / r1;
  printf "%-24s %10.3f %12.1f %10.2f\n", "1 rank x 2 threads", r12, r12 * b * 2, r12 / r1;
  printf "parallel efficiency at 2 ranks: %.1f%% (target >= 85%%)\n", 100 * r2 / (2 * r1);
}'
if [[ -n "${BASELINE:-}" ]]; then
  echo "# baseline ${BASELINE}, 2x1 steps/s per repeat: $(paste -sd' ' base.txt)"
  awk -v r2="${r2}" -v b="$(median < base.txt)" 'BEGIN {
    printf "against the baseline at 2 ranks: %.3f / %.3f steps/s = %.2fx\n", r2, b, r2 / b }'
fi
