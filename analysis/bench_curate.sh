#!/usr/bin/env bash
# Curation timings: the cluster tree on 10,000 frames (target: build < 2 s, a query < 1 ms),
# measured by the tree's own test on 10,000 feature rows, and `facecap curate build` / `query`
# end to end on a real clip (features included).
#   analysis/bench_curate.sh [build-dir]
set -euo pipefail
BUILD="${1:-build}"
FACECAP="$BUILD/facecap"
PHOTO=/usr/share/matplotlib/mpl-data/sample_data/grace_hopper.jpg
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

echo "tree on 10,000 frames (pose 9, lighting 3, flat expression; query 2, 3, 1):"
"$BUILD/tests/facecap_curate_test" --gtest_filter='*TenThousandFrames*' | grep "tree build" | sed 's/^/  /'

ffmpeg -loglevel error -y -f lavfi -i color=c=gray:s=640x480:r=25:d=8 -loop 1 -i "$PHOTO" \
  -filter_complex "[1]scale=-2:360[p];[0][p]overlay=x=(W-w)/2+100*sin(t):y=(H-h)/2:shortest=1" \
  -t 8 -pix_fmt yuv420p -c:v libx264 "$WORK/clip.mp4"
"$FACECAP" ingest --video "$WORK/clip.mp4" --out "$WORK/frames.h5" >/dev/null 2>&1
echo "end to end on a 200-frame real clip:"
"$FACECAP" curate build --frames "$WORK/frames.h5" --out "$WORK/curation.h5" 2>&1 | grep "curate build" | sed 's/.*curate build: /  build: /'
"$FACECAP" curate query --curation "$WORK/curation.h5" --frame 17 --out "$WORK/picks.h5" \
  --sheet "$WORK/picks.png" 2>&1 | grep "unique frames" | sed 's/.*curate query: /  query: /'
