#!/usr/bin/env bash
# Synthetic-sample throughput (issue 4 target: 4,000 samples at 128x128 in at most 15 s with
# 2 ranks): `facecap synth samples --count N --size 128` on 1 rank and on 2 ranks, printing
# samples per second and the 1-rank to 2-rank speedup (one OpenMP thread per rank, so the
# speedup is the parallel efficiency of the rank loop, gathers and rank-0 writes included),
# measured side by side in one run, and checks that both runs wrote the same segmentations.
# Each process pays a fixed start-up (loading the shared libraries) inside the figures.
#
#   analysis/bench_synth.sh [BUILD_DIR] [-- extra `synth samples` options]
#
# BUILD_DIR defaults to $FACECAP_BUILD_DIR, then build/ under the source tree. COUNT (default
# 4000) sets the number of samples. The last line is one JSON object with the figures.
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
set -- ${rest[@]+"${rest[@]}"}
count="${COUNT:-4000}"

build_targets facecap
require_facecap

tmp_dir="$(mktemp -d)"
trap 'rm -rf "${tmp_dir}"' EXIT
cores="$(getconf _NPROCESSORS_ONLN)"
"${facecap}" rig demo --out "${tmp_dir}/rig.h5" >/dev/null

# Seconds of wall time of a command (its output goes to LOG).
timed() {
  local log="$1"
  shift
  local start end
  start="$(date +%s.%N)"
  "$@" >"${log}" 2>&1 || { cat "${log}" >&2; echo "error: $* failed" >&2; exit 1; }
  end="$(date +%s.%N)"
  echo "${end} - ${start}" | bc -l
}

args=(synth samples --rig "${tmp_dir}/rig.h5" --count "${count}" --size 128 "$@")
echo "# facecap synth samples benchmark: ${count} samples at 128x128 ($(uname -m), ${cores} cores, load $(cut -d' ' -f1 /proc/loadavg))"
t1="$(OMP_NUM_THREADS=1 timed "${tmp_dir}/one.log" "${facecap}" "${args[@]}" --out "${tmp_dir}/one.h5")"
t2="$(OMP_NUM_THREADS=1 timed "${tmp_dir}/two.log" mpirun -n 2 --oversubscribe --allow-run-as-root \
      -x OMP_NUM_THREADS "${facecap}" "${args[@]}" --out "${tmp_dir}/two.h5")"
if ! h5diff -q "${tmp_dir}/one.h5" "${tmp_dir}/two.h5" /samples/segmentation; then
  echo "warning: the 1-rank and 2-rank segmentations differ" >&2
fi
size_mb="$(du -m "${tmp_dir}/one.h5" | cut -f1)"
rate1="$(echo "${count} / ${t1}" | bc -l)"
rate2="$(echo "${count} / ${t2}" | bc -l)"
speedup="$(echo "${t1} / ${t2}" | bc -l)"
printf "%-28s %10s %14s\n" "run" "seconds" "samples/s"
printf "%-28s %10.2f %14.1f\n" "1 rank x 1 thread" "${t1}" "${rate1}"
printf "%-28s %10.2f %14.1f\n" "2 ranks x 1 thread" "${t2}" "${rate2}"
printf "speedup 1 -> 2 ranks: %.2fx; target: %s samples in <= 15 s with 2 ranks: %s; output %s MB\n" \
  "${speedup}" "${count}" "$(echo "${t2} <= 15 * ${count} / 4000" | bc -l | sed 's/1/met/;s/0/missed/')" "${size_mb}"
printf '{"count": %s, "size": 128, "seconds_1_rank": %.3f, "seconds_2_ranks": %.3f, "samples_per_second_1_rank": %.1f, "samples_per_second_2_ranks": %.1f, "speedup": %.3f, "output_mb": %s}\n' \
  "${count}" "${t1}" "${t2}" "${rate1}" "${rate2}" "${speedup}" "${size_mb}"
