#!/usr/bin/env bash
# Texture network training (textures train) on 1 and on 2 ranks, one tensor thread per rank
# and the same global batch: steps per second of each and the parallel efficiency
# (two-rank rate / (2 x one-rank rate)), as the ratio of two runs on the same machine.
#
#   analysis/bench_texture_training.sh [BUILD_DIR] [-- SCANS]
#
# SCANS: a textured scan database (default: out/dynamic_textures/scans.h5, which
# analysis/dynamic_textures.sh makes). Environment: WORK (out/bench_texture_training),
# STEPS (60 optimizer steps per run).
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
set -- "${rest[@]}"
build_targets facecap
require_facecap
scans="${1:-out/dynamic_textures/scans.h5}"
[[ -f "${scans}" ]] || { echo "error: ${scans} not found; run analysis/dynamic_textures.sh first or pass -- SCANS" >&2; exit 1; }
work="$(mkdir -p "${WORK:-out/bench_texture_training}" && cd "${WORK:-out/bench_texture_training}" && pwd)"
steps="${STEPS:-60}"

# Steps per second of one run on $1 ranks, from the stage's "N steps in S s" line; the batch
# is 8 expressions, and the run makes whole epochs of at least $steps steps.
rate() {
  local out="${work}/ranks$1.h5" examples epochs
  rm -f "${out}" "${out}.checkpoint"
  examples=$(/usr/bin/python3 -c "import h5py,sys; f=h5py.File(sys.argv[1],'r'); s=f['scans/people/split'][:]; print(int((s==0).sum())*f['scans/people/expressions'].shape[1])" "${scans}")
  epochs=$(( (steps * 8 + examples - 1) / examples ))
  "${mpirun_cmd[@]}" -n "$1" "${facecap}" textures train --scans "${scans}" --out "${out}" --threads 1 \
      --epochs "${epochs}" --checkpoint-every 1000000 2>&1 |
    sed -n 's/.* \([0-9]*\) steps in \([0-9.]*\) s .*/\1 \2/p' | awk '{printf "%.4f\n", $1 / $2}'
}
one=$(rate 1)
two=$(rate 2)
/usr/bin/python3 - "${one}" "${two}" <<'PY'
import sys
one, two = float(sys.argv[1]), float(sys.argv[2])
print(f"textures train, batch 8, one thread per rank: 1 rank {one:.3f} steps/s, 2 ranks {two:.3f} steps/s, "
      f"efficiency {two / one / 2 * 100:.0f}% (target >= 85%)")
PY
