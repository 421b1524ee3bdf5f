#!/usr/bin/env bash
# The Slurm scripts on a real single-node Slurm (tests/slurm/local_cluster.sh):
#   1. pipeline.sbatch runs a small job file on 2 tasks; its outputs equal a direct run.
#   2. a job signalled with SIGUSR1 before its time limit (as --signal=B:USR1@120 does)
#      checkpoints, requeues itself, and finishes with the same result as an uninterrupted run.
#   3. sweep.sbatch runs a job array over two job files.
# Usage: slurm_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
SOURCE_DIR="$1"
BUILD_DIR="$2"
WORK="$(mktemp -d)"
CLUSTER="$WORK/cluster"
source "$SOURCE_DIR/tests/slurm/local_cluster.sh"
cleanup() {
  local_cluster_stop "$CLUSTER"
  rm -rf "$WORK"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
# What Slurm knows of a job that did not end as expected: its record and the daemons' last lines.
diagnose() {  # job
  scontrol show job "$1" >&2 || true
  tail -n 30 "$CLUSTER/log/slurmctld.log" "$CLUSTER/log/slurmd.log" >&2 || true
}

local_cluster_start "$CLUSTER" || fail "could not start the local Slurm cluster"
export FACECAP="$BUILD_DIR/facecap" FACECAP_SLURM_DIR="$SOURCE_DIR/slurm"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

job_state() { scontrol show job "$1" | grep -oE 'JobState=[A-Z_]+' | cut -d= -f2; }
job_restarts() { scontrol show job "$1" | grep -oE 'Restarts=[0-9]+' | cut -d= -f2; }
wait_state() {  # job, state, seconds
  local i
  for i in $(seq 1 $(( $3 * 2 ))); do
    [ "$(job_state "$1")" = "$2" ] && return 0
    sleep 0.5
  done
  return 1
}
same_datasets() {  # a.h5 b.h5 dataset...
  local a="$1" b="$2" d
  shift 2
  for d in "$@"; do
    h5diff -q "$a" "$b" "$d" "$d" || fail "$d differs between $a and $b"
  done
}
write_job() {  # dir count
  mkdir -p "$1"
  cat > "$1/job.toml" <<TOML
[run]
stages = ["rig.demo", "synth.samples"]
[rig.demo]
out = "rig.h5"
[synth.samples]
rig = "rig.h5"
out = "samples.h5"
count = $2
size = 64
batch = 8
TOML
}
DATASETS=(/samples/segmentation /samples/weights /samples/pose /samples/landmarks /samples/landmark_visible)

# Reference: the same stages run directly, uninterrupted.
write_job "$WORK/ref" 3000
(cd "$WORK/ref" && "$FACECAP" run job.toml >/dev/null 2>&1) || fail "direct run failed"

echo "== 1. pipeline.sbatch on 2 tasks"
write_job "$WORK/one" 3000
cd "$WORK/one"
jid=$(sbatch --parsable "$SOURCE_DIR/slurm/pipeline.sbatch" job.toml)
wait_state "$jid" COMPLETED 120 || { cat facecap-pipeline-*.out; diagnose "$jid"; fail "job $jid ended $(job_state "$jid")"; }
grep -q "pipeline job.toml complete" facecap-pipeline-"$jid".out || fail "no completion line"
grep -q "r0/2" facecap-pipeline-"$jid".out || fail "the stages did not run on 2 ranks"
same_datasets "$WORK/ref/samples.h5" samples.h5 "${DATASETS[@]}"
echo "ok"

echo "== 2. SIGUSR1 before the time limit: checkpoint, requeue, same result"
write_job "$WORK/two" 3000
cd "$WORK/two"
jid=$(sbatch --parsable "$SOURCE_DIR/slurm/pipeline.sbatch" job.toml)
for i in $(seq 1 120); do
  grep -q "synth samples: runs" facecap-pipeline-"$jid".out 2>/dev/null && [ -f samples.h5.partial ] && break
  sleep 0.25
done
sleep 0.5
scancel --signal=USR1 --batch "$jid"
for i in $(seq 1 120); do
  [ "$(job_restarts "$jid")" = "1" ] && [ "$(job_state "$jid")" = "PENDING" ] && break
  sleep 0.5
done
[ "$(job_restarts "$jid")" = "1" ] || { cat facecap-pipeline-"$jid".out; diagnose "$jid"; fail "job $jid was not requeued"; }
grep -q "checkpointed; requeueing" facecap-pipeline-"$jid".out || fail "no checkpoint line"
grep -q "stopped by signal after" facecap-pipeline-"$jid".out || fail "the stage did not stop on the signal"
# Slurm holds a requeued batch job for the credential lifetime plus a second (the local cluster
# sets cred_expire=10; clusters' default is 120 s), until the node has forgotten the first run's
# revoked credential. Released earlier, the rerun can be refused at launch ("Job credential
# revoked") and end FAILED without running the script.
wait_state "$jid" COMPLETED 120 || { cat facecap-pipeline-"$jid".out; diagnose "$jid"; fail "job $jid ended $(job_state "$jid")"; }
grep -q "continuing" facecap-pipeline-"$jid".out || fail "the requeued run did not continue the checkpoint"
same_datasets "$WORK/ref/samples.h5" samples.h5 "${DATASETS[@]}"
echo "ok"

echo "== 3. sweep.sbatch over two job files"
write_job "$WORK/sweep/a" 200
write_job "$WORK/sweep/b" 300
cd "$WORK/sweep"
printf '%s\n' a/job.toml b/job.toml > list.txt
# Each job file's outputs are relative to where facecap runs: run each in its own directory.
sed -i 's|out = "|out = "'"$WORK/sweep"'/DIR/|; s|rig = "rig.h5"|rig = "'"$WORK/sweep"'/DIR/rig.h5"|' a/job.toml b/job.toml
sed -i 's|/DIR/|/a/|g' a/job.toml
sed -i 's|/DIR/|/b/|g' b/job.toml
jid=$(sbatch --parsable --array=0-1 "$SOURCE_DIR/slurm/sweep.sbatch" list.txt)
for task in 0 1; do
  wait_state "${jid}_${task}" COMPLETED 120 || { cat facecap-sweep-*.out; diagnose "${jid}_${task}"; fail "array task $task ended $(job_state "${jid}_${task}")"; }
done
[ "$(h5dump -H a/samples.h5 | grep -c 'DATASPACE  SIMPLE { ( 200')" -ge 1 ] || fail "sweep a/samples.h5 has the wrong size"
[ "$(h5dump -H b/samples.h5 | grep -c 'DATASPACE  SIMPLE { ( 300')" -ge 1 ] || fail "sweep b/samples.h5 has the wrong size"
echo "ok"
echo "3 passed, 0 failed"
