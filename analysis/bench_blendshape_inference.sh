#!/usr/bin/env bash
# Blendshape inference time per person on one core (paper 001 Sec. 4, Table 1): one neutral mesh
# to its 55 personalized blendshapes, as `facecap blendshapes infer` does it (geometry image of
# the neutral, Estimation and Tuning generators, offsets back on the vertices), beside the
# target of 50 ms per person.
#
# Each run is a fresh `blendshapes infer` pinned to one core (taskset, OMP_NUM_THREADS=1,
# --threads 1: one tensor and one OpenMP thread) whose log line times the inference alone
# (model loading and file output excluded). The first run warms the file cache and is dropped;
# the median of the others is the figure. With the scan database it built itself, the script
# also prints the evaluation's own timing (eval blendshapes: inference_ms_per_person, the mean
# over every person of the database, the first included). CALLGRIND=1 adds the instruction count
# of one inference (callgrind; repeatable on a busy machine; takes a few minutes).
#
# Usage: analysis/bench_blendshape_inference.sh [build dir] [model.h5 neutral.obj]
#   Without a model: a small one is trained first (12 people, 64 x 64 geometry images as in
#   jobs/blendshapes.toml, one epoch per stage; the timing does not depend on training).
#   RUNS (default 21), CPU (the core, default 0), OUT (work folder, default
#   out/bench_blendshape_inference).
set -euo pipefail
BUILD=${1:-build}
FACECAP="$BUILD/facecap"
MODEL=${2:-}
NEUTRAL=${3:-}
RUNS=${RUNS:-21}
CPU=${CPU:-0}
OUT=${OUT:-out/bench_blendshape_inference}
TARGET_MS=50
mkdir -p "$OUT"
export OMP_NUM_THREADS=1
PIN=()
if command -v taskset >/dev/null; then PIN=(taskset -c "$CPU"); fi

SCANS=""
if [[ -z "$MODEL" ]]; then
  SCANS="$OUT/scans.h5"
  MODEL="$OUT/bsgen.h5"
  [[ -f "$SCANS" ]] || "$FACECAP" scans synth --people 12 --test-people 2 --out "$SCANS" >/dev/null 2>&1
  [[ -f "$MODEL" ]] || "${PIN[@]}" "$FACECAP" blendshapes train --scans "$SCANS" --image-size 64 \
      --estimation-epochs 1 --tuning-epochs 1 --threads 1 --out "$MODEL" >/dev/null 2>&1
fi
if [[ -z "$NEUTRAL" ]]; then
  # The last person's neutral of the scan database (or, for a given model, its template) as OBJ.
  SOURCE=${SCANS:-$MODEL}
  NEUTRAL="$OUT/neutral.obj"
  if [[ -n "$SCANS" ]]; then
    dims=$(h5ls "$SCANS/scans/people/neutral" | sed 's/.*{\([0-9]*\)\/[A-Za-z]*, \([0-9]*\), 3}.*/\1 \2/')
    read -r people vertices <<<"$dims"
    h5dump -y -w 0 -m '%.9g' -d /scans/people/neutral -s "$((people - 1)),0,0" -c "1,$vertices,3" \
        -o "$OUT/vertices.txt" "$SOURCE" >/dev/null
  else
    h5dump -y -w 0 -m '%.9g' -d /template/neutral -o "$OUT/vertices.txt" "$SOURCE" >/dev/null
  fi
  h5dump -y -w 0 -d /template/triangles -o "$OUT/triangles.txt" "$SOURCE" >/dev/null
  {
    tr -s ', \n' '\n\n\n' <"$OUT/vertices.txt" | grep -v '^$' | paste -d' ' - - - | sed 's/^/v /'
    tr -s ', \n' '\n\n\n' <"$OUT/triangles.txt" | grep -v '^$' | paste -d' ' - - - |
        awk '{print "f", $1 + 1, $2 + 1, $3 + 1}'
  } >"$NEUTRAL"
fi

echo "== blendshapes infer on one core ($RUNS runs, the first dropped) =="
times=()
for ((r = 0; r < RUNS; ++r)); do
  ms=$("${PIN[@]}" "$FACECAP" blendshapes infer --model "$MODEL" --neutral "$NEUTRAL" --threads 1 \
        --out "$OUT/rig.h5" 2>&1 | sed -n 's/.*blendshapes infer: [0-9]* shapes in \([0-9.]*\) ms.*/\1/p')
  [[ -n "$ms" ]] || { echo "blendshapes infer failed" >&2; exit 1; }
  times+=("$ms")
done
python3 - "$TARGET_MS" "${times[@]}" <<'PY'
import statistics, sys
target = float(sys.argv[1])
t = [float(x) for x in sys.argv[3:]]  # the first run is the warm-up
median = statistics.median(t)
print(f"inference per person, one core: median {median:.1f} ms over {len(t)} runs "
      f"(min {min(t):.1f}, max {max(t):.1f}; warm-up run {float(sys.argv[2]):.1f})   "
      f"target <= {target:.0f} ms: {'met' if median <= target else 'NOT met'}")
PY

if [[ -n "$SCANS" ]]; then
  echo "== eval blendshapes on one core (mean over the database's people, the first included) =="
  [[ -f "$OUT/baselines.h5" ]] || "$FACECAP" blendshapes baselines --scans "$SCANS" --iterations 1 \
      --out "$OUT/baselines.h5" >/dev/null 2>&1
  "${PIN[@]}" "$FACECAP" eval blendshapes --scans "$SCANS" --baselines "$OUT/baselines.h5" --model "$MODEL" \
      --json 2>/dev/null | tail -n 1 | sed -n 's/.*"inference_ms_per_person": \([0-9.]*\).*/inference_ms_per_person \1 ms/p'
fi

if [[ "${CALLGRIND:-0}" == 1 ]]; then
  echo "== instructions of one inference (callgrind) =="
  valgrind --tool=callgrind --toggle-collect='*LoadedModel::Personalize*' --callgrind-out-file="$OUT/callgrind.out" \
      "$FACECAP" blendshapes infer --model "$MODEL" --neutral "$NEUTRAL" --threads 1 --out "$OUT/rig.h5" 2>&1 |
      sed -n 's/.*Collected : \([0-9]*\).*/\1/p' | awk '{printf "%.1f million instructions per person\n", $1 / 1e6}'
fi
