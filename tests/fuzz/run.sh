#!/usr/bin/env bash
# Builds the fuzz targets (build-fuzz/: clang, libFuzzer, AddressSanitizer, UBSan) and runs each
# for SECONDS_PER_TARGET seconds (default 60), one after another, on a copy of its seed corpus
# (tests/fuzz/corpus/<target>/). Prints one line per target: executions, seconds, coverage and
# the result. Exits non-zero when any target crashed, hit a sanitizer report (undefined
# behaviour halts too), leaked, timed out (10 s an input) or ran out of memory (2 GiB); the
# input that did it is kept in build-fuzz/fuzz/artifacts/<target>/ and the log in
# build-fuzz/fuzz/logs/<target>.log.
#
#   tests/fuzz/run.sh [SECONDS_PER_TARGET] [TARGET...]
#
# FACECAP_BUILD_JOBS limits the build's parallel jobs (default: every core).
set -uo pipefail
cd "$(dirname "$0")/../.."
SECONDS_PER_TARGET="${1:-60}"
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(job_file obj frames_h5 rig_h5 track_h5)
case "$SECONDS_PER_TARGET" in
  ''|*[!0-9]*) echo "usage: tests/fuzz/run.sh [SECONDS_PER_TARGET] [TARGET...]" >&2; exit 2 ;;
esac

BUILD=build-fuzz
JOBS="${FACECAP_BUILD_JOBS:-$(nproc)}"
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DFACECAP_FUZZ=ON >/dev/null || { echo "run.sh: configuring $BUILD failed" >&2; exit 1; }
cmake --build "$BUILD" -j "$JOBS" || { echo "run.sh: building $BUILD failed" >&2; exit 1; }

WORK="$BUILD/fuzz"
mkdir -p "$WORK/logs"
# Scratch files of the targets (the HDF5 and OBJ files they write, in memory when /dev/shm is
# writable), removed afterwards.
SCRATCH_BASE="${TMPDIR:-/tmp}"
[ -d /dev/shm ] && [ -w /dev/shm ] && SCRATCH_BASE=/dev/shm
SCRATCH="$(mktemp -d "$SCRATCH_BASE/facecap_fuzz.XXXXXX")"
trap 'rm -rf "$SCRATCH"' EXIT
export FACECAP_FUZZ_SCRATCH="$SCRATCH"
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:symbolize=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:report_error_type=1:symbolize=1"

failed=0
summary=()
for target in "${TARGETS[@]}"; do
  binary="$BUILD/fuzz_$target"
  seeds="tests/fuzz/corpus/$target"
  if [ ! -x "$binary" ] || [ ! -d "$seeds" ]; then
    echo "run.sh: no target $target" >&2
    exit 2
  fi
  corpus="$WORK/corpus/$target"
  artifacts="$WORK/artifacts/$target/"
  log="$WORK/logs/$target.log"
  rm -rf "$corpus"
  mkdir -p "$corpus" "$artifacts"
  cp "$seeds"/* "$corpus"/
  # The structure-aware targets decode edits from the whole input: inputs of any length up to
  # 512 bytes from the start, rather than lengths grown slowly from the tiny seeds.
  extra=()
  case "$target" in *_h5) extra=(-len_control=0 -max_len=512) ;; esac
  start=$(date +%s)
  "$binary" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 "${extra[@]}" -artifact_prefix="$artifacts" "$corpus" >"$log" 2>&1
  rc=$?
  seconds=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  coverage=$(grep -o 'cov: [0-9]* ft: [0-9]*' "$log" | tail -1)
  if [ "$rc" -eq 0 ]; then
    result="ok"
  else
    failed=1
    artifact=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$log" | tail -1)
    result="FAILED (exit $rc${artifact:+, input $artifact}; log $log)"
    echo "---- $target: the end of $log"
    grep -E '^(==[0-9]+==ERROR|SUMMARY|FUZZ FAILURE)|runtime error|uncaught exception|#[0-9]+ 0x' \
      "$log" | head -40
  fi
  summary+=("$(printf '%-10s %10s executions %5ss  %-22s %s' "$target" "${execs:-?}" \
    "$seconds" "${coverage:-}" "$result")")
done

echo "---- fuzzing, ${SECONDS_PER_TARGET}s per target"
printf '%s\n' "${summary[@]}"
exit "$failed"
