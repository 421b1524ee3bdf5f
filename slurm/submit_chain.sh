#!/usr/bin/env bash
# Submits one Slurm job per stage of a job file, chained with --dependency=afterok, so each
# stage can ask for its own resources (sbatch options per stage via FACECAP_SBATCH_<TABLE>,
# with dots as underscores: FACECAP_SBATCH_deepfake_train="--ntasks=8 --time=08:00:00").
#
#   slurm/submit_chain.sh jobs/my_actor.toml [facecap run options]
# Prints the job ids, first stage first.
set -euo pipefail
JOB_FILE="${1:?usage: slurm/submit_chain.sh JOB.toml [facecap run options]}"
shift
HERE="$(cd "$(dirname "$0")" && pwd)"
FACECAP="${FACECAP:-$(pwd)/build/facecap}"
previous=""
for stage in $("$FACECAP" run "$JOB_FILE" --list "$@"); do
  var="FACECAP_SBATCH_${stage//./_}"
  extra="${!var:-}"
  dependency=()
  [ -n "$previous" ] && dependency=(--dependency="afterok:${previous}")
  # shellcheck disable=SC2086
  previous=$(sbatch --parsable --job-name="facecap-${stage}" "${dependency[@]}" $extra \
    --export=ALL,FACECAP_SLURM_DIR="$HERE",FACECAP="$FACECAP" \
    "$HERE/stage.sbatch" "$JOB_FILE" "$stage" "$@")
  echo "$previous $stage"
done
