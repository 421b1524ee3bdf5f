#!/usr/bin/env bash
# The speed figures of README's Figures table in one run, each beside the baseline measured in
# the same run (1 rank against 2, the icosphere against the head, torch::mm's rate against a
# training step's), and the deepfake and blendshape trainers' arithmetic rates against this
# machine's single-precision matrix-multiply rate. Then the accuracy figures of the demo, the
# lip-sync and the blendshapes jobs, each beside the trivial answer or the oracle of the same
# job (analysis/accuracy_rows.py): with ACCURACY_JOBS=1 the jobs are run first (2 ranks; a job
# whose outputs are up to date is skipped; about 1 hour from nothing), else the outputs found
# in out/ are read.
#
#   [ACCURACY_JOBS=1] analysis/bench_all.sh [BUILD_DIR]
#
# Writes every script's output to LOGS (default out/bench_all/) and the summary to
# LOGS/summary.md. The speed part takes about 10 minutes on 2 cores; run it on an otherwise
# idle machine.
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
logs="$(mkdir -p "${LOGS:-out/bench_all}" && cd "${LOGS:-out/bench_all}" && pwd)"
out_demo="${OUT_DEMO:-out/demo}"
build_targets facecap facecap_bench_render facecap_bench_train_rate facecap_curate_test
require_facecap

summary="${logs}/summary.md"
{
  echo "# facecap speed figures, $(date -u +%Y-%m-%d), $(getconf _NPROCESSORS_ONLN) cores, $(git -C "${source_dir}" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo
  echo "| figure | measured in this run (baseline beside it) | script |"
  echo "| --- | --- | --- |"
} > "${summary}"

# run NAME COMMAND...: the command's output to LOGS/NAME.log; a failure is reported, not fatal.
run() {
  local name="$1"
  shift
  echo "== ${name}: $*" >&2
  local start=${SECONDS}
  if ! "$@" > "${logs}/${name}.log" 2>&1; then
    echo "| ${name} | FAILED (see ${logs}/${name}.log) | |" >> "${summary}"
    return 1
  fi
  echo "   done in $((SECONDS - start)) s" >&2
}
# row FIGURE SCRIPT LOG PATTERN...: the log's lines matching the patterns (every match of
# each), joined.
row() {
  local figure="$1" script="$2" log="${logs}/$3"
  shift 3
  local found=""
  for pattern in "$@"; do
    local line
    line="$(grep -E -o -- "${pattern}.*" "${log}" 2>/dev/null | sed 's/^ *//; s/|/\//g; s/  */ /g' |
            paste -sd ';' - | sed 's/;/; /g' || true)"
    [[ -n "${line}" ]] && found="${found:+${found}; }${line}"
  done
  echo "| ${figure} | ${found:-not found in ${log}} | \`${script}\` |" >> "${summary}"
}

analysis="${source_dir}/analysis"
if run render "${analysis}/bench_render.sh" "${build_dir}"; then
  row "render: renders per second per core, 128x128 (head / icosphere)" bench_render.sh render.log \
    "segmentation_renders_per_second"
fi
if run synth "${analysis}/bench_synth.sh" "${build_dir}"; then
  row "synth samples: 4,000 at 128x128, 1 and 2 ranks (seconds, samples/s)" bench_synth.sh synth.log \
    "1 rank x 1 thread" "2 ranks x 1 thread" "speedup 1 -> 2"
fi
if run ingest "${analysis}/bench_ingest.sh" "${build_dir}"; then
  row "ingest: 640x480 H.264, 1 and 2 ranks" bench_ingest.sh ingest.log "1 rank x 1 thread:" "2 ranks x 1 thread:"
fi
if run curate "${analysis}/bench_curate.sh" "${build_dir}"; then
  row "curate: tree build on 10,000 frames, queries" bench_curate.sh curate.log \
    "tree build on" "query: [0-9]+ query"
fi
if run track "${analysis}/bench_track.sh" "${build_dir}"; then
  row "track: solve per frame per core, 2 ranks against 1" bench_track.sh track.log \
    "solve time per frame" "parallel efficiency"
fi
if run deepfake "${analysis}/bench_deepfake.sh" "${build_dir}"; then
  row "deepfake training: 2 ranks against 1" bench_deepfake.sh deepfake.log "parallel efficiency"
fi
if run train_rate env OMP_NUM_THREADS=1 GLOG_minloglevel=2 "${build_dir}/facecap_bench_train_rate"; then
  row "deepfake and blendshape training steps against torch::mm, one thread" facecap_bench_train_rate \
    train_rate.log "^matmul peak" "^deepfake training step" "^blendshape Estimation" "^blendshape Tuning"
fi

# Accuracy: the jobs' outputs (run from the source folder, where the job files write out/).
if [[ "${ACCURACY_JOBS:-0}" == 1 ]]; then
  for job in demo lipsync blendshapes; do
    run "job_${job}" bash -c "cd '${source_dir}' && ${mpirun_cmd[*]} -n 2 '${facecap}' run jobs/${job}.toml" || true
  done
fi
blendshapes_json="${logs}/blendshapes.json"
if [[ -f "${source_dir}/out/blendshapes/bsgen.h5" ]]; then
  (cd "${source_dir}" && "${facecap}" eval blendshapes --job jobs/blendshapes.toml --json 2>/dev/null |
     grep '^{' > "${blendshapes_json}") || rm -f "${blendshapes_json}"
fi
{
  echo
  echo "## Accuracy, each beside its baseline in the same job"
  echo
  /usr/bin/python3 "${analysis}/accuracy_rows.py" --demo "${out_demo}" \
    --lipsync "${source_dir}/out/lipsync" --blendshapes "${blendshapes_json}"
} >> "${summary}"
cat "${summary}"
