# Shared by the facecap Slurm scripts (sourced, not run).
#
# FACECAP      the facecap binary (default: build/facecap under the submit directory)
# FACECAP_SRUN how each stage is launched (default: srun --mpi=pmix, one rank per task)
#
# Time limits: the scripts are submitted with --signal=B:USR1@120, so Slurm sends SIGUSR1 to
# the batch shell two minutes before the limit. The shell passes it to the running stage, which
# writes its checkpoint and exits with code 75; the shell then requeues the job
# (scontrol requeue, array-aware) and the rerun continues where it stopped.

FACECAP="${FACECAP:-${SLURM_SUBMIT_DIR:-$PWD}/build/facecap}"
FACECAP_SRUN="${FACECAP_SRUN:-srun --mpi=pmix}"
# One OpenMP thread team per rank, sized by --cpus-per-task.
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-${SLURM_CPUS_PER_TASK:-1}}"
# srun inherits the task's CPU count from the allocation in Slurm >= 22.05.
export SRUN_CPUS_PER_TASK="${SRUN_CPUS_PER_TASK:-${SLURM_CPUS_PER_TASK:-1}}"
# Many file systems of clusters (NFS, Lustre without flock) break HDF5's file locks.
export HDF5_USE_FILE_LOCKING="${HDF5_USE_FILE_LOCKING:-FALSE}"
# OpenMPI refuses root without these; harmless otherwise.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none

facecap_job_id() {
  if [ -n "${SLURM_ARRAY_JOB_ID:-}" ] && [ -n "${SLURM_ARRAY_TASK_ID:-}" ]; then
    echo "${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}"
  else
    echo "${SLURM_JOB_ID}"
  fi
}

FACECAP_CHILD=""
facecap_on_usr1() {
  echo "facecap: SIGUSR1 (time limit near): asking the running stage to checkpoint" >&2
  [ -n "$FACECAP_CHILD" ] && kill -USR1 "$FACECAP_CHILD" 2>/dev/null
}
trap facecap_on_usr1 USR1

# Runs a command in the background and waits for it, so that the USR1 trap runs while it works
# (bash runs traps only between commands). Returns the command's exit code.
facecap_step() {
  "$@" &
  FACECAP_CHILD=$!
  local code
  while true; do
    wait "$FACECAP_CHILD"
    code=$?
    # wait returns > 128 when a trapped signal interrupted it: keep waiting for the stage.
    if [ $code -gt 128 ] && kill -0 "$FACECAP_CHILD" 2>/dev/null; then continue; fi
    break
  done
  FACECAP_CHILD=""
  return $code
}

# Handles a stage's exit code: 75 means checkpointed after a signal, so requeue.
facecap_after_step() {
  local code="$1" what="$2"
  if [ "$code" -eq 75 ]; then
    echo "facecap: $what checkpointed; requeueing job $(facecap_job_id)" >&2
    scontrol requeue "$(facecap_job_id)"
    exit 0
  fi
  if [ "$code" -ne 0 ]; then
    echo "facecap: $what failed with exit code $code (see README, Exit codes)" >&2
    exit "$code"
  fi
}
