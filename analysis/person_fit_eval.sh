#!/usr/bin/env bash
# The person fit on people no setting was tuned on: for each identity seed, a clip filmed as in
# jobs/demo.toml, ingested from its mp4, translated by one deepfake trained on the crops of all
# of them (B) with the demo's samples and the paired frames of its four other people (A), and
# fitted by `person fit` as the job fits; `eval person` against each person's true neutral, beside the generic head and the
# landmarks-only fit, and the fit on the clip's true segmentation of the crops (the ceiling
# with a perfect deepfake). Prints a markdown table and the means.
#
#   analysis/person_fit_eval.sh
#
# Environment: SEEDS ("101 102 103 104 105 106 107 108"), STEPS (deepfake steps, the job's
# default), RANKS (2), WORK (out/person_eval), FACECAP_BUILD_DIR (build/).
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
facecap="${build_dir}/facecap"
[[ -x "${facecap}" ]] || { echo "error: ${facecap} not built" >&2; exit 1; }
seeds="${SEEDS:-101 102 103 104 105 106 107 108}"
ranks="${RANKS:-2}"
work="$(mkdir -p "${WORK:-out/person_eval}" && cd "${WORK:-out/person_eval}" && pwd)"
job="${source_dir}/jobs/demo.toml"
steps_flag=()
[[ -n "${STEPS:-}" ]] && steps_flag=(--steps "${STEPS}")

run() { mpirun --oversubscribe --allow-run-as-root -n "${ranks}" "${facecap}" "$@"; }
log() { echo "[person_fit_eval] $*" >&2; }

# Shared: the calibrated generic head, domain A and the paired frames, as the demo makes them.
log "shared stages (rig, samples, paired frames)"
(cd "${work}" && mkdir -p shared && cd shared &&
  run run "${job}" --until synth.crops-paired14 >shared.log 2>&1)
shared="${work}/shared/out/demo"
paired="$(ls "${shared}"/paired[0-9]*.h5 | paste -sd, -)"

# Per person: the clip, its ingest, the truth's segmentation of the crops.
for s in ${seeds}; do
  d="${work}/id_${s}"
  mkdir -p "${d}/out/demo"
  cp -f "${shared}/rig.h5" "${shared}/rig_generic.h5" "${d}/out/demo/"
  log "identity ${s}: clip, ingest"
  (cd "${d}" && for stage in synth.clip ingest synth.crops-truth; do
     run run "${job}" --only "${stage}" --set "synth.clip.identity_seed=${s}" >>run.log 2>&1
   done)
done

# One deepfake for all of them: B is every person's crops.
log "deepfake on the crops of all people"
/usr/bin/python3 - "${work}/b_all.h5" ${seeds} <<EOF
import sys, h5py, numpy as np
out, seeds = sys.argv[1], sys.argv[2:]
crops, found = [], []
for s in seeds:
    with h5py.File("${work}/id_%s/out/demo/frames.h5" % s, "r") as f:
        crops.append(f["/frames/crop"][...]); found.append(f["/frames/found"][...])
with h5py.File(out, "w") as f:
    f["/frames/crop"] = np.concatenate(crops); f["/frames/found"] = np.concatenate(found)
EOF
[[ -f "${work}/deepfake.h5" ]] || run deepfake train --a "${shared}/samples.h5" --b "${work}/b_all.h5" \
  --b-dataset /frames/crop --paired "${paired}" --out "${work}/deepfake.h5" \
  "${steps_flag[@]}" >"${work}/deepfake.log" 2>&1

printf "| identity | generic head | landmarks only | person fit | person fit / generic | true segmentation |\n"
printf "|---|---|---|---|---|---|\n"
for s in ${seeds}; do
  d="${work}/id_${s}/out/demo"
  run deepfake infer --model "${work}/deepfake.h5" --frames "${d}/frames.h5" --dataset /frames/crop \
    --out "${d}/translated.h5" >>"${work}/id_${s}/run.log" 2>&1
  run person fit --rig "${d}/rig.h5" --frames "${d}/frames.h5" --translations "${d}/translated.h5" \
    --out "${d}/person.h5" >>"${work}/id_${s}/run.log" 2>&1
  run person fit --rig "${d}/rig.h5" --frames "${d}/frames.h5" --translations "${d}/crops_truth.h5" \
    --translations-dataset /frames/segmentation --out "${d}/person_oracle.h5" >>"${work}/id_${s}/run.log" 2>&1
  "${facecap}" eval person --truth "${d}/clip.h5" --person "${d}/person.h5" --json >"${d}/person.json"
  "${facecap}" eval person --truth "${d}/clip.h5" --person "${d}/person_oracle.h5" --json >"${d}/person_oracle.json"
  /usr/bin/python3 - "${d}/person.json" "${d}/person_oracle.json" "${s}" <<'EOF'
import json, sys
m, o = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
print("| %s | %.4f | %.4f | %.4f | %.2f | %.4f |" % (
    sys.argv[3], m["template_vertex_rms_over_iod"], m["landmarks_only_vertex_rms_over_iod"],
    m["vertex_rms_over_iod"], m["vertex_rms_over_iod"] / m["template_vertex_rms_over_iod"],
    o["vertex_rms_over_iod"]))
EOF
done | tee "${work}/table.md"
/usr/bin/python3 - "${work}" ${seeds} <<'EOF'
import json, sys
work, seeds = sys.argv[1], sys.argv[2:]
rows = [json.load(open("%s/id_%s/out/demo/person.json" % (work, s))) for s in seeds]
orc = [json.load(open("%s/id_%s/out/demo/person_oracle.json" % (work, s))) for s in seeds]
mean = lambda k, r=rows: sum(x[k] for x in r) / len(r)
print("| mean | %.4f | %.4f | %.4f | %.2f | %.4f |" % (
    mean("template_vertex_rms_over_iod"), mean("landmarks_only_vertex_rms_over_iod"),
    mean("vertex_rms_over_iod"), mean("vertex_rms_over_iod") / mean("template_vertex_rms_over_iod"),
    mean("vertex_rms_over_iod", orc)))
EOF
