#!/usr/bin/env bash
# Contraction and expansion of the random samples (paper 000 Sec. 7.1-7.2), measured on the
# demo: the tracker's errors against the clip's truth with a deepfake trained on the raw
# 4,000 samples and on the contracted and expanded 4,000, every other stage and option the
# demo's, the person's rig the demo's. Each deepfake seed in SEEDS trains once per set; the
# raw set with seed 1 is the demo's own deepfake (out/demo/metrics.json). Rows beside them:
# the neutral face (weights), and the oracle (the true segmentation tracked with the true rig).
#
#   analysis/sample_set.sh [BUILD_DIR]
#
# About 17 minutes per trained deepfake on 2 cores (run jobs/demo.toml first).
# Environment: RANKS (2), SEEDS ("1 2"), WORK (out/sample_set), DEMO (out/demo),
# FACECAP_BUILD_DIR (build/).
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
require_facecap
ranks="${RANKS:-2}"
seeds="${SEEDS:-1 2}"
demo="$(cd "${DEMO:-out/demo}" && pwd)"
for f in samples.h5 deepfake.h5 translated.h5 track.h5 person.h5 metrics.json metrics_oracle.json; do
  [[ -f "${demo}/${f}" ]] || { echo "error: ${demo}/${f} missing: run jobs/demo.toml first" >&2; exit 1; }
done
work="$(mkdir -p "${WORK:-out/sample_set}" && cd "${WORK:-out/sample_set}" && pwd)"
job="${source_dir}/jobs/dataset.toml"

run() { "${mpirun_cmd[@]}" -n "${ranks}" "${facecap}" "$@"; }
log() { echo "[sample_set] $*" >&2; }

rows=()
for seed in ${seeds}; do
  for set in raw expanded; do
    if [[ "${set}" == raw && "${seed}" == 1 ]]; then
      rows+=("raw 4000, seed 1 (the demo)=${demo}/metrics.json")
      continue
    fi
    d="${work}/${set}_seed${seed}"
    mkdir -p "${d}/out"
    ln -sfn "${demo}" "${d}/out/demo"
    extra=(--set "deepfake.train.seed=${seed}")
    [[ "${set}" == raw ]] && extra+=(--set "deepfake.train.a=out/demo/samples.h5")
    log "${set} set, deepfake seed ${seed}"
    start=$(date +%s)
    (cd "${d}" && run run "${job}" "${extra[@]}" >run.log 2>&1) ||
      { echo "error: jobs/dataset.toml failed; see ${d}/run.log" >&2; exit 1; }
    log "${set} set, seed ${seed}: $(( $(date +%s) - start )) s"
    label="contracted + expanded 4000"
    [[ "${set}" == raw ]] && label="raw 4000"
    rows+=("${label}, seed ${seed}=${d}/out/dataset/metrics.json")
  done
done

/usr/bin/python3 - "${demo}" "${work}" "${rows[@]}" <<'EOF'
import json, sys
import h5py
demo, work, rows = sys.argv[1], sys.argv[2], sys.argv[3:]
any_set = next((r.split("=", 1)[1] for r in rows if "expanded" in r), None)
if any_set:
    d = any_set.rsplit("/", 1)[0]
    with h5py.File(f"{d}/contracted.h5", "r") as f:
        removed = int(f["/contraction"].attrs["removed"])
        total = len(f["/contraction/score"])
    with h5py.File(f"{d}/expanded.h5", "r") as f:
        gaps = len(f["/expansion/gap_frames"])
        new = int(f["/samples/origin"][:].sum())
    with h5py.File(f"{d}/expanded_check.h5", "r") as f:
        above = int(f["/contraction"].attrs["removed"])
    print(f"\ncontraction removed {removed} of {total} samples; {gaps} gap frames seeded {new} new "
          f"samples, {above} of which score above the contraction's bound\n")
print("| deepfake trained on | pose (deg) | weight MAE | active MAE | landmark NME | expression err |")
print("| --- | --- | --- | --- | --- | --- |")
def row(name, m, neutral=False):
    if neutral:
        print(f"| {name} | | {m['weights_mae_neutral']:.4f} | {m['active_weights_mae_neutral']:.3f} | "
              f"| {m['expression_err_rel_neutral']:.4f} |")
        return
    print(f"| {name} | {m['pose_err_deg_mean']:.3f} | {m['weights_mae']:.4f} | "
          f"{m['active_weights_mae']:.3f} | {m['landmark_nme']:.4f} | {m['expression_err_rel']:.4f} |")
for r in rows:
    name, path = r.split("=", 1)
    row(name, json.load(open(path)))
row("neutral face", json.load(open(f"{demo}/metrics.json")), neutral=True)
row("oracle: true segmentation, true rig", json.load(open(f"{demo}/metrics_oracle.json")))
EOF
