#!/usr/bin/env bash
# One command from a sweep's outputs to a table and plots.
#
#   analysis/sweep_report.sh SWEEP_DIR [OUT_DIR]
#
# SWEEP_DIR holds one folder per run (as slurm/sweep.sbatch leaves them), each with a
# metrics.json from `facecap eval ... --json` and, where present, clip.h5 + track.h5.
# Writes OUT_DIR/metrics.csv, OUT_DIR/metrics.md, and per run OUT_DIR/<run>/yaw.png and
# errors.png. Uses Debian's /usr/bin/python3 with python3-h5py and python3-matplotlib.
set -euo pipefail
SWEEP="${1:?usage: analysis/sweep_report.sh SWEEP_DIR [OUT_DIR]}"
OUT="${2:-$SWEEP/report}"
HERE="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$OUT"
/usr/bin/python3 "$HERE/collect_metrics.py" --out "$OUT/metrics" "$SWEEP"
for run in "$SWEEP"/*/; do
  name="$(basename "$run")"
  [ "$name" = "$(basename "$OUT")" ] && continue
  if [ -f "$run/clip.h5" ] && [ -f "$run/track.h5" ]; then
    /usr/bin/python3 "$HERE/plot_track.py" --truth "$run/clip.h5" --track "$run/track.h5" \
      --out "$OUT/$name"
  fi
done
echo "sweep_report: $OUT/metrics.md"
