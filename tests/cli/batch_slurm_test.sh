#!/bin/bash
# `haha batch` on a REAL one-node Slurm cluster (docs/scale-out.md): its own munged,
# slurmctld and slurmd with their config and state under WORKDIR (SLURM_CONF points there;
# nothing in /etc is used), started here and stopped by their process ids. A 3-subject job
# array of tiny synthetic subjects (seeds 1, 2, 3; the third with a corrupt image):
#   - two avatars land and load (`haha info`); the broken subject ends as bad input (exit 65,
#     failed.json with its reason) and is not retried;
#   - the same subjects one after another (no Slurm) for the wall-time comparison;
#   - a task cancelled mid-training (scancel) and submitted again resumes, and its avatar.glb
#     is byte-identical to the uninterrupted array task's;
#   - the array submitted again does no work (every output untouched), also through the
#     documented job script scripts/scale-out/haha-array-cpu.sbatch.
# Usage: batch_slurm_test.sh HAHA WORKDIR. Exit 77 (skipped) without slurm-wlm / munge or root.
set -u -o pipefail
HAHA=$(readlink -f "$1")
W=$(mkdir -p "$2" && readlink -f "$2")

skip() { echo "SKIP: $*"; exit 77; }
for tool in munged munge slurmctld slurmd sbatch squeue scancel sinfo; do
  command -v "$tool" >/dev/null || skip "$tool not found: install slurm-wlm and munge (HAHA_WITH_SLURM=1 bash scripts/install-deps.sh)"
done
[ "$(id -u)" = 0 ] || skip "needs root (slurmd runs the jobs; run the test as root)"

FAILURES=0
check() {  # check DESCRIPTION COMMAND...
  local what=$1; shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what"; FAILURES=$((FAILURES + 1)); fi
}
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }

rm -rf "$W"
mkdir -p "$W/munge" "$W/msock" "$W/slurm/state" "$W/slurm/spool" "$W/data"
chmod 700 "$W/munge"
chmod 755 "$W" "$W/msock"
PIDS=()
OUR_CLUSTER=0  # 1 once SLURM_CONF points at this test's cluster (never scancel on another one)
cleanup() {
  # This cluster's jobs first (SLURM_CONF is ours), then the daemons by their pids.
  [ "$OUR_CLUSTER" = 1 ] && scancel --quiet --user="$(id -un)" 2>/dev/null && sleep 1
  for pid in "${PIDS[@]}"; do kill "$pid" 2>/dev/null; done
  for pid in "${PIDS[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null
  done
}
trap cleanup EXIT

# ---- munge: its own key and socket ----
dd if=/dev/urandom of="$W/munge/munge.key" bs=1024 count=1 2>/dev/null
chmod 400 "$W/munge/munge.key"
SOCK="$W/msock/munge.socket.2"
munged -F --socket="$SOCK" --key-file="$W/munge/munge.key" --pid-file="$W/munge/munged.pid" \
  --log-file="$W/munge/munged.log" --seed-file="$W/munge/munged.seed" 2>"$W/munge/stderr" &
PIDS+=($!)
for _ in $(seq 50); do [ -S "$SOCK" ] && break; sleep 0.1; done
[ -S "$SOCK" ] || { cat "$W/munge/stderr"; echo "FAIL: munged did not start"; exit 1; }

# ---- slurm: a localhost cluster of one node ----
HOST=$(hostname)
PORT=$((20000 + RANDOM % 20000))
export SLURM_CONF="$W/slurm/slurm.conf"
OUR_CLUSTER=1
cat >"$SLURM_CONF" <<CONF
ClusterName=hahatest
SlurmctldHost=$HOST
SlurmctldPort=$PORT
SlurmdPort=$((PORT + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$SOCK
StateSaveLocation=$W/slurm/state
SlurmdSpoolDir=$W/slurm/spool
SlurmctldPidFile=$W/slurm/slurmctld.pid
SlurmdPidFile=$W/slurm/slurmd.pid
SlurmctldLogFile=$W/slurm/slurmctld.log
SlurmdLogFile=$W/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
KillWait=30
MinJobAge=600
SchedulerParameters=sched_interval=1
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
NodeName=$HOST CPUs=2 State=UNKNOWN
PartitionName=batch Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -i -f "$SLURM_CONF" 2>"$W/slurm/slurmctld.stderr" &
PIDS+=($!)
sleep 1
slurmd -D -f "$SLURM_CONF" 2>"$W/slurm/slurmd.stderr" &
PIDS+=($!)
for _ in $(seq 100); do
  state=$(sinfo -h -o %t 2>/dev/null)
  [ "$state" = idle ] && break
  sleep 0.2
done
if [ "$state" != idle ]; then
  tail -20 "$W/slurm/slurmctld.log" "$W/slurm/slurmd.log" "$W/slurm/"*.stderr
  echo "FAIL: the node did not come up (sinfo: '$state')"
  exit 1
fi
echo "cluster up: $HOST, slurmctld port $PORT, pids ${PIDS[*]}"

# ---- three tiny subjects ----
for seed in 1 2 3; do
  "$HAHA" synth --out "$W/data/d$seed" --size 48 --frames 8 --test-frames 2 --body-resolution low --supersample 1 \
    --seed "$seed" >/dev/null || { echo "FAIL: haha synth"; exit 1; }
done
# The third: a corrupt image (the dataset reader names it: bad input).
img=$(ls "$W/data/d3/images" | head -1)
printf 'this is not an image' >"$W/data/d3/images/$img"
S1=${HAHA_BATCH_SLURM_S1_STEPS:-60}  # stage-1 steps (a larger value for the wall-time comparison)
cat >"$W/manifest.txt" <<MANIFEST
# tiny subjects: a few steps of each stage, a checkpoint every step (for the cancel below)
* preset=tiny resolution=48 s0.steps=0 s1.steps=$S1 s2.steps=10 s3.steps=10 checkpoint_every=1 s1.densify.from=10 s1.densify.every=15 s1.densify.until=45 s3.prune_every=5 s2.texture_size=32 eval:tto-steps=0
s1 data/d1
s2 data/d2
s3-broken data/d3
MANIFEST
cat >"$W/job.sh" <<'JOB'
#!/bin/bash
#SBATCH --job-name=haha-batch
#SBATCH --cpus-per-task=1
#SBATCH --output=%x-%A_%a.out
"$HAHA" batch run "$MANIFEST" --out "$ROOT"
rc=$?
mkdir -p "$ROOT/.codes" && echo "$rc" >>"$ROOT/.codes/$SLURM_ARRAY_TASK_ID"
exit "$rc"
JOB
export HAHA MANIFEST="$W/manifest.txt"
cd "$W"

wait_job() {  # wait_job JOBID: until no task of it is queued or running
  for _ in $(seq 3000); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 0.2
  done
  echo "FAIL: job $1 did not end"; squeue; return 1
}
submit() {  # submit ROOT ARRAY: prints the job id
  ROOT="$1" sbatch --parsable --array="$2" "$W/job.sh" | cut -d';' -f1
}

# ---- the array ----
t0=$(now)
job=$(submit "$W/array" 0-2) || { echo "FAIL: sbatch"; exit 1; }
wait_job "$job"
t_array=$(since "$t0")
"$HAHA" batch status "$MANIFEST" --out "$W/array"
for id in s1 s2; do
  check "$id: done.json and avatar.glb" test -f "$W/array/$id/done.json" -a -f "$W/array/$id/avatar.glb"
  check "$id: avatar.glb loads (haha info)" bash -c "'$HAHA' info '$W/array/$id/avatar.glb' >/dev/null"
done
check "s3-broken: exit code 65 once" test "$(cat "$W/array/.codes/2" 2>/dev/null)" = 65
check "s3-broken: failed.json kind bad_input" grep -q '"kind": "bad_input"' "$W/array/s3-broken/failed.json"
check "s3-broken: the reason names the corrupt image" grep -q "$img" "$W/array/s3-broken/failed.json"
check "s3-broken: one attempt" grep -q '"attempts": 1' "$W/array/s3-broken/failed.json"
check "s1, s2: exit code 0" test "$(cat "$W/array/.codes/0" "$W/array/.codes/1" 2>/dev/null | tr -d '\n')" = 00

# ---- the same subjects one after another, no scheduler, all cores each ----
t0=$(now)
for i in 0 1 2; do "$HAHA" batch run "$MANIFEST" --index "$i" --out "$W/serial" >/dev/null 2>&1; done
t_serial=$(since "$t0")
check "serial: two avatars" test -f "$W/serial/s1/avatar.glb" -a -f "$W/serial/s2/avatar.glb"

# ---- cancelled mid-training, submitted again: resumes to the same bytes ----
job=$(submit "$W/cancel" 1)
for _ in $(seq 3000); do  # the first checkpoint (step 1), then SIGTERM well before step 60
  [ -f "$W/cancel/s2/run/checkpoint.npz" ] && break
  sleep 0.05
done
scancel "$job"
wait_job "$job"
check "cancelled: not done" test ! -f "$W/cancel/s2/done.json"
check "cancelled: failed.json retryable, interrupted in train" \
  bash -c "grep -q '\"kind\": \"retryable\"' '$W/cancel/s2/failed.json' && grep -q '\"stage\": \"train\"' '$W/cancel/s2/failed.json'"
"$HAHA" batch status "$MANIFEST" --out "$W/cancel" | grep -E "^ +1 "
job=$(submit "$W/cancel" 1)
wait_job "$job"
check "resubmitted: done on attempt 2" grep -q '"attempts": 2' "$W/cancel/s2/done.json"
check "resubmitted: training resumed" grep -q '"resumed": true' "$W/cancel/s2/done.json"
check "resubmitted: the log says where it resumed" grep -q "resumed .* at stage" "$W/cancel/s2/log.txt"
check "resubmitted: avatar.glb byte-identical to the uninterrupted task's" cmp "$W/cancel/s2/avatar.glb" "$W/array/s2/avatar.glb"

# ---- the array again: no work ----
before=$(cd "$W/array" && find . -path ./.codes -prune -o -type f ! -name '.lock' -printf '%p %T@ %s\n' | sort | md5sum)
t0=$(now)
job=$(submit "$W/array" 0-2)
wait_job "$job"
t_again=$(since "$t0")
after=$(cd "$W/array" && find . -path ./.codes -prune -o -type f ! -name '.lock' -printf '%p %T@ %s\n' | sort | md5sum)
check "again: every output untouched" test "$before" = "$after"
check "again: the done ones say so" bash -c "grep -l 'already done' '$W'/haha-batch-${job}_0.out '$W'/haha-batch-${job}_1.out | wc -l | grep -qx 2"
check "again: the broken one is not retried" grep -q "not retried" "$W/haha-batch-${job}_2.out"
check "again: codes 0 0 65" test "$(tail -qn1 "$W/array/.codes/0" "$W/array/.codes/1" "$W/array/.codes/2" | tr '\n' ' ')" = "0 0 65 "
# The documented job script (scripts/scale-out/haha-array-cpu.sbatch), its resources scaled
# down to this node: the same array, no work, the bad input neither retried nor requeued.
SCRIPT="$(dirname "$(readlink -f "$0")")/../../scripts/scale-out/haha-array-cpu.sbatch"
job=$(sbatch --parsable --array=0-2 --cpus-per-task=1 --mem=0 --time=10 --output="$W/doc-%A_%a.out" \
  "$SCRIPT" "$MANIFEST" "$W/array" | cut -d';' -f1)
wait_job "$job"
after2=$(cd "$W/array" && find . -path ./.codes -prune -o -type f ! -name '.lock' -printf '%p %T@ %s\n' | sort | md5sum)
check "documented sbatch script: outputs untouched" test "$before" = "$after2"
check "documented sbatch script: done ones skipped" bash -c "grep -l 'already done' '$W'/doc-${job}_0.out '$W'/doc-${job}_1.out | wc -l | grep -qx 2"
check "documented sbatch script: bad input not retried, not requeued" \
  bash -c "grep -q 'not retried' '$W/doc-${job}_2.out' && grep -q '\"attempts\": 1' '$W/array/s3-broken/failed.json'"
"$HAHA" batch status "$MANIFEST" --out "$W/array" --json >"$W/status.json"
check "status --json: 2 done, 1 failed" grep -q '"done": 2' "$W/status.json"

printf 'wall time: array (2 CPUs, 1 per task) %.1f s; one after another (2 threads each) %.1f s; array again (no work) %.1f s\n' \
  "$t_array" "$t_serial" "$t_again"
echo "$t_array $t_serial $t_again" >"$W/wall_times.txt"
[ "$FAILURES" = 0 ] || { echo "$FAILURES check(s) failed; logs under $W"; exit 1; }
echo "all checks passed"
