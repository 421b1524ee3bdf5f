#!/usr/bin/env bash
# Ingest throughput at 640x480 on real footage: a 12 s, 25 fps H.264 clip of a camera moving
# over the Grace Hopper portrait of Debian's python-matplotlib-data (made here with ffmpeg).
# Prints frames per second per core (1 rank x 1 thread), and at 2 ranks for the parallel
# efficiency. Target: >= 10 frames/s per core.
#   analysis/bench_ingest.sh [build-dir]
set -euo pipefail
BUILD="${1:-build}"
FACECAP="$BUILD/facecap"
PHOTO=/usr/share/matplotlib/mpl-data/sample_data/grace_hopper.jpg
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
ffmpeg -loglevel error -y -f lavfi -i color=c=gray:s=640x480:r=25:d=12 -loop 1 -i "$PHOTO" \
  -filter_complex "[1]scale=-2:360[p];[0][p]overlay=x=(W-w)/2+100*sin(t):y=(H-h)/2+20*cos(t):shortest=1" \
  -t 12 -pix_fmt yuv420p -c:v libx264 "$WORK/clip.mp4"
FRAMES=300

run() {  # ranks out
  local ranks=$1 out=$2 start end
  start=$(date +%s.%N)
  if [ "$ranks" -eq 1 ]; then
    "$FACECAP" ingest --video "$WORK/clip.mp4" --out "$out" --threads 1 >"$WORK/log" 2>&1
  else
    mpirun --oversubscribe --allow-run-as-root -n "$ranks" "$FACECAP" ingest \
      --video "$WORK/clip.mp4" --out "$out" --threads 1 >"$WORK/log" 2>&1
  fi
  end=$(date +%s.%N)
  grep "ingest summary" "$WORK/log" | sed 's/.*ingest summary: /  summary: /'
  python3 -c "print(f'{$end - $start:.3f}')"
}

echo "ingest benchmark: $FRAMES frames, 640x480 H.264, detection on a 480-px copy, every frame"
t1=$(run 1 "$WORK/f1.h5" | tee /dev/stderr | tail -1)
t2=$(run 2 "$WORK/f2.h5" | tee /dev/stderr | tail -1)
python3 - "$t1" "$t2" "$FRAMES" <<'PY'
import sys
t1, t2, n = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
print(f"1 rank x 1 thread: {t1:.2f} s, {n / t1:.1f} frames/s per core (target >= 10; includes "
      f"the ~1 s model load)")
print(f"2 ranks x 1 thread: {t2:.2f} s, {n / t2:.1f} frames/s, parallel efficiency "
      f"{t1 / (2 * t2) * 100:.0f}% (the machine's other load counts too)")
PY
