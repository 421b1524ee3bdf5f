#!/usr/bin/env bash
# Blendshape generation figures (paper 001 Sec. 4, Table 2), measured side by side:
#   1. the comparison table of jobs/blendshapes.toml (runs the job first if needed, 2 ranks),
#   2. training throughput on 1 and on 2 ranks (1 thread each) and the parallel efficiency,
#   3. inference time per person on one core (from the evaluation),
#   4. what a method that sees only the neutral can reach (analysis/blendshapes_ceiling.py).
# Usage: analysis/bench_blendshapes.sh [build dir]   (run from the repository root)
set -euo pipefail
BUILD=${1:-build}
FACECAP="$BUILD/facecap"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
MPIRUN="mpirun --oversubscribe"
JOB=jobs/blendshapes.toml
OUT=out/blendshapes

$MPIRUN -n 2 "$FACECAP" run "$JOB"
echo "== comparison (mean per-vertex error, mm) =="
"$FACECAP" eval blendshapes --job "$JOB" --json | tail -n 1
cat "$OUT/table.md"

echo "== training efficiency, 1 vs 2 ranks (1 thread per rank, same global batch) =="
steps_per_second() {  # ranks
  local out="$OUT/bench_ranks$1.h5"
  rm -f "$out" "$out.checkpoint"
  # The stage logs "N steps in S s (...)": steps per second from that line.
  $MPIRUN -n "$1" "$FACECAP" blendshapes train --job "$JOB" --threads 1 --estimation-epochs 3 \
      --tuning-epochs 1 --out "$out" 2>&1 | sed -n 's/.* \([0-9]*\) steps in \([0-9.]*\) s .*/\1 \2/p' |
      awk '{print $1 / $2}'
}
one=$(steps_per_second 1)
two=$(steps_per_second 2)
python3 - "$one" "$two" <<'PY'
import sys
one, two = float(sys.argv[1]), float(sys.argv[2])
print(f"1 rank: {one:.3f} steps/s   2 ranks: {two:.3f} steps/s   speedup {two/one:.2f}   "
      f"efficiency {two/one/2*100:.0f}% (target >= 85%)")
PY

echo "== what a method that sees only the neutral can reach on this database =="
# Shapes built from the database's own terms (true g, f, h; g learnt from the training people)
# against ours, scored like the comparison above (analysis/blendshapes_ceiling.py explains).
"$FACECAP" eval blendshapes --job "$JOB" --shapes "$OUT/shapes.h5" > /dev/null
/usr/bin/python3 analysis/blendshapes_ceiling.py --scans "$OUT/scans.h5" --shapes "$OUT/shapes.h5" 2> /dev/null
