#!/usr/bin/env bash
# End to end on a real scheduler: stands up a single-node Slurm (Debian slurm-wlm and munge; as
# root, without systemd: munged, slurmctld and slurmd started here, with a generated minimal
# slurm.conf in a temporary folder), submits a real job array that renders a short sequence in
# chunks (each task takes its chunk from SLURM_ARRAY_TASK_ID: no --shard on the command line),
# renders the same frames in one run, and compares the files byte for byte. Then it reruns one
# task the way `cubetrace farm slurm` documents (the same index, `sbatch --array=I`,
# --skip-existing) after deleting that task's frames, and checks that exactly those come back,
# equal, and no other file is rewritten. Exits non-zero on any difference or failed task; Slurm
# is torn down (and the temporary folder removed) on every exit.
#
# Run as root: `tests/slurm/array.sh` (.ci/run runs it when CUBETRACE_SLURM_TEST=1).
# Settings (environment): CUBETRACE (the binary; default target/release/cubetrace, built if
# missing), SCENE (default sphere-room-orbit), FRAMES (default 1..6), TASKS (array size,
# default 3), WIDTH (default 64), KEEP=1 keeps the temporary folder.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD

SCENE=${SCENE:-sphere-room-orbit}
FRAMES=${FRAMES:-1..6}
TASKS=${TASKS:-3}
WIDTH=${WIDTH:-64}
CUBETRACE=${CUBETRACE:-$ROOT/target/release/cubetrace}

say() { echo "slurm-test: $*"; }
fail() { echo "slurm-test: FAIL: $*" >&2; exit 1; }

[ "$(id -u)" = 0 ] || fail "run as root (it starts munged, slurmctld and slurmd)"

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
  || ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
  say "installing slurm-wlm and munge (apt-get)"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    slurm-wlm munge >/dev/null
fi
if [ ! -x "$CUBETRACE" ]; then
  say "building $CUBETRACE"
  cargo build --release --locked
fi
CUBETRACE=$(readlink -f "$CUBETRACE")
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
# The single run below and the check must not see a scheduler of their own.
unset SLURM_ARRAY_TASK_ID SLURM_ARRAY_TASK_COUNT SLURM_ARRAY_TASK_MIN SLURM_ARRAY_TASK_MAX \
  SLURM_ARRAY_TASK_STEP JOB_COMPLETION_INDEX

WORK=$(mktemp -d /tmp/cubetrace-slurm.XXXXXX)
chmod 755 "$WORK"
PIDS=()
MUNGED_PID=
teardown() {
  local rc=$?
  set +e
  if [ -n "${JOB:-}" ] && [ -n "$(squeue -h -j "$JOB" 2>/dev/null)" ]; then
    scancel "$JOB" 2>/dev/null
  fi
  [ -n "$MUNGED_PID" ] && PIDS=("$MUNGED_PID" "${PIDS[@]}")
  for ((i = ${#PIDS[@]} - 1; i >= 0; i--)); do
    kill "${PIDS[i]}" 2>/dev/null
  done
  for p in "${PIDS[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.2; done
    kill -9 "$p" 2>/dev/null
  done
  if [ "$rc" != 0 ] && [ -d "$WORK/log" ]; then
    for f in "$WORK"/log/*; do echo "--- $f"; tail -n 20 "$f"; done >&2
  fi
  if [ "${KEEP:-0}" = 1 ]; then say "kept $WORK"; else rm -rf "$WORK"; fi
  say "Slurm torn down"
  exit "$rc"
}
trap teardown EXIT
trap 'exit 130' INT TERM

mkdir -p "$WORK"/{log,spool,state,munge,out,single,job}
HOST=$(hostname -s)
CPUS=$(nproc)

# munge: its own socket, log and seed in the temporary folder, run as the munge user.
chown munge:munge "$WORK/munge"
chmod 755 "$WORK/munge"
if [ ! -s /etc/munge/munge.key ]; then
  say "creating /etc/munge/munge.key"
  mungekey --create --keyfile /etc/munge/munge.key 2>/dev/null \
    || { dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null; }
  chown munge:munge /etc/munge/munge.key
  chmod 400 /etc/munge/munge.key
fi
SOCK=$WORK/munge/munge.socket
# munged forks; its pid comes from its pid file (teardown stops it by that id).
runuser -u munge -- munged --socket="$SOCK" --log-file="$WORK/munge/munged.log" \
  --pid-file="$WORK/munge/munged.pid" --seed-file="$WORK/munge/munged.seed"
for _ in $(seq 50); do [ -S "$SOCK" ] && break; sleep 0.2; done
[ -S "$SOCK" ] || fail "munged did not start (see $WORK/munge/munged.log)"
MUNGED_PID=$(cat "$WORK/munge/munged.pid")
munge --socket="$SOCK" -n | unmunge --socket="$SOCK" >/dev/null || fail "munge round trip"

export SLURM_CONF=$WORK/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=cubetrace-test
SlurmctldHost=$HOST(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$SOCK
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$WORK/spool
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/log/slurmctld.log
SlurmdLogFile=$WORK/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MinJobAge=600
NodeName=$HOST NodeAddr=127.0.0.1 CPUs=$CPUS State=UNKNOWN
PartitionName=test Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -f "$SLURM_CONF" >"$WORK/log/slurmctld.stderr" 2>&1 &
PIDS+=($!)
slurmd -D -f "$SLURM_CONF" >"$WORK/log/slurmd.stderr" 2>&1 &
PIDS+=($!)
for _ in $(seq 100); do
  state=$(sinfo -h -o %t 2>/dev/null || true)
  [ "$state" = idle ] && break
  sleep 0.3
done
[ "$state" = idle ] || fail "the node did not come up (sinfo: '${state:-no answer}')"
say "single-node Slurm up: $(sinfo -h -o '%P %D nodes %c CPUs %t') ($(sinfo -V))"

# Waits for job $1 (sbatch --parsable), then checks that each of its tasks completed with exit 0.
wait_job() {
  local job=$1 want=$2
  for _ in $(seq 1200); do
    [ -z "$(squeue -h -j "$job" 2>/dev/null)" ] && break
    sleep 0.5
  done
  [ -z "$(squeue -h -j "$job")" ] || fail "job $job did not finish in 10 minutes"
  local lines
  lines=$(scontrol -o show job "$job")
  echo "$lines" | sed -E 's/.*(JobId=[0-9]+ ArrayJobId=[0-9]+ ArrayTaskId=[0-9]+).*(JobState=[A-Z_]+).*(ExitCode=[0-9:]+).*/  \1 \2 \3/'
  local done_ok
  done_ok=$(echo "$lines" | grep -c 'JobState=COMPLETED .*ExitCode=0:0' || true)
  [ "$done_ok" = "$want" ] || fail "job $job: $done_ok of $want tasks completed with exit 0"
}

RENDER=(render "$SCENE" --frames "$FRAMES" --width "$WIDTH")
LAST=$((TASKS - 1))
cat >"$WORK/job/array.sbatch" <<JOB
#!/bin/bash
#SBATCH --job-name=cubetrace-array
#SBATCH --array=0-$LAST
#SBATCH --cpus-per-task=1
#SBATCH --output=$WORK/log/task-%a.out
echo "task on \$(hostname): \$(env | grep '^SLURM_ARRAY_TASK_' | sort | tr '\n' ' ')"
exec "$CUBETRACE" -v ${RENDER[*]} -o "$WORK/out/f-####.png"
JOB
say "sbatch --array=0-$LAST: cubetrace ${RENDER[*]} -o $WORK/out/f-####.png (no --shard: the chunk comes from SLURM_ARRAY_TASK_ID)"
JOB=$(sbatch --parsable "$WORK/job/array.sbatch")
wait_job "$JOB" "$TASKS"
for f in "$WORK"/log/task-*.out; do
  echo "  --- $(basename "$f")"
  grep -E '^[^[]|shard' "$f" | sed 's/^/  /'
done

say "one run: cubetrace ${RENDER[*]} -o $WORK/single/f-####.png"
"$CUBETRACE" "${RENDER[@]}" -o "$WORK/single/f-####.png" | sed 's/^/  /'

# Byte for byte: the same names, and every file equal.
compare() {
  local a=$1 b=$2 na nb
  na=$(cd "$a" && ls) nb=$(cd "$b" && ls)
  [ "$na" = "$nb" ] || fail "different files: [$(echo $na)] vs [$(echo $nb)]"
  [ -n "$na" ] || fail "no frames in $a"
  for f in $na; do cmp "$a/$f" "$b/$f" || fail "$f differs"; done
  echo "$na" | wc -l
}
n=$(compare "$WORK/out" "$WORK/single")
say "$n frames from $TASKS array tasks are byte-identical to one run: $(cd "$WORK/out" && echo *)"
# The comparison can fail: two different frames differ.
first=$(cd "$WORK/single" && ls | head -1)
second=$(cd "$WORK/single" && ls | sed -n 2p)
if cmp -s "$WORK/out/$first" "$WORK/single/$second"; then
  fail "negative: $first and $second are equal, the comparison shows nothing"
fi
say "negative: $first (array) and $second (one run) differ, as cmp must see"

# A failed task rerun as `cubetrace farm slurm` documents: its frames deleted, the same index
# resubmitted with `sbatch --array=K`; the script passes --shard K/N and --skip-existing.
K=$LAST
"$CUBETRACE" farm slurm --tasks "$TASKS" --cpus-per-task 1 --log "$WORK/log/rerun-%a.out" \
  -o "$WORK/job/farm.sbatch" -- "${RENDER[@]}" -o "$WORK/out/f-####.png"
# Chunk K of the frames a..b, computed here on its own: positions floor(i*len/N) .. floor((i+1)*len/N).
lo=${FRAMES%..*} hi=${FRAMES#*..}
len=$((hi - lo + 1))
mine=()
for ((p = K * len / TASKS; p < (K + 1) * len / TASKS; p++)); do
  mine+=("$(printf 'f-%04d.png' $((lo + p)))")
done
[ ${#mine[@]} -gt 0 ] || fail "task $K has no frames (FRAMES=$FRAMES, TASKS=$TASKS)"
for f in "${mine[@]}"; do rm "$WORK/out/$f"; done
before=$(cd "$WORK/out" && stat -c '%n %i %Y' *)
say "deleted task $K's frames (${mine[*]}); sbatch --array=$K farm.sbatch"
grep -E '^#SBATCH --array|^exec' "$WORK/job/farm.sbatch" | sed 's/^/  /'
JOB=$(CUBETRACE=$CUBETRACE sbatch --parsable --array="$K" "$WORK/job/farm.sbatch")
wait_job "$JOB" 1
grep -E '^[^[]|shard' "$WORK/log/rerun-$K.out" | sed 's/^/  /'
n=$(compare "$WORK/out" "$WORK/single")
after=$(cd "$WORK/out" && stat -c '%n %i %Y' $(cd "$WORK/out" && ls | grep -vxF -f <(printf '%s\n' "${mine[@]}")))
[ "$before" = "$after" ] || fail "the rerun rewrote other frames: [$before] vs [$after]"
say "rerun of task $K: its ${#mine[@]} frames are back and equal, the other frames untouched; $n frames byte-identical to one run"
say "PASS"
