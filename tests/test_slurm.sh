#!/usr/bin/env bash
# scripts/slurm_bake.sh on a real one-node Slurm cluster that this test stands up on the
# machine and tears down itself (docs/farm.md):
#   1. munged with a fresh key, slurmctld and slurmd on 127.0.0.1 at free ports, every socket,
#      state, spool and log file in a temporary folder (no cgroups, no accounting), as root;
#   2. 8 sample frames baked as a 4-task array (chunk 2) and its verify job: every output
#      written, every task and the verify job COMPLETED with exit 0, each task given its chunk,
#      a log and a summary per task, summary.json with 8 frames done;
#   3. one output deleted: `vdbscatter bake --verify` exits 3 and names it missing; then only
#      its task resubmitted with --tasks: the frame is baked again, its chunk partner is left
#      up to date, and the new verify job passes.
# Skips (exit 77) when not root or without munged/slurmctld/slurmd/sbatch (scripts/setup.sh
# installs them). Every wait is bounded; the daemons are stopped on any exit, and their logs
# printed on failure. VDBSCATTER_SLURM_KEEP=1 keeps the temporary folder.
# Usage: VDBSCATTER=path/to/vdbscatter tests/test_slurm.sh  (ctest sets it)
set -euo pipefail
me=test_slurm
src=$(cd "$(dirname "$0")/.." && pwd)
PATH=$PATH:/usr/sbin:/sbin

if [ -z "${VDBSCATTER:-}" ] || [ ! -x "$VDBSCATTER" ]; then
  echo "$me: FAIL: VDBSCATTER must name the vdbscatter binary (got '${VDBSCATTER:-}')" >&2
  exit 1
fi
vdbscatter=$(cd "$(dirname "$VDBSCATTER")" && pwd)/$(basename "$VDBSCATTER")
if [ "$(id -u)" -ne 0 ]; then
  echo "$me: SKIP: needs root (it runs munged, slurmctld and slurmd of its own)"
  exit 77
fi
for b in munged slurmctld slurmd sbatch scontrol squeue sinfo scancel python3; do
  if ! command -v "$b" >/dev/null; then
    echo "$me: SKIP: no $b on PATH (scripts/setup.sh installs munge, slurmctld, slurmd and slurm-client)"
    exit 77
  fi
done

started=$SECONDS
deadline=$((started + 540)) # every wait together: 9 minutes (ctest's limit is 10)
step() {
  echo "$me: [$((SECONDS - started)) s] $*"
}
fail() {
  echo "$me: FAIL: $*" >&2
  exit 1
}

# A Slurm job of ours must not inherit the settings of one this test may itself run in.
while IFS='=' read -r name _; do
  unset "$name"
done < <(env | grep -E '^(SLURM|SBATCH|SALLOC|SRUN)_[A-Za-z0-9_]*=' || true)

tmp=$(mktemp -d "${TMPDIR:-/tmp}/vdbs-slurm.XXXXXX")
chmod 755 "$tmp"
cluster=$tmp/cluster
work=$tmp/work
logs=$work/logs
mkdir -p "$cluster/munge" "$cluster/munge-socket" "$cluster/state" "$cluster/spool" \
  "$cluster/log" "$work"
chmod 700 "$cluster/munge"
daemons=() # "name pid", stopped in reverse order

stop_pid() { # $1 name, $2 pid: TERM, up to 10 s, then KILL
  local name=$1 pid=$2 i
  kill -0 "$pid" 2>/dev/null || return 0
  kill -TERM "$pid" 2>/dev/null || true
  for ((i = 0; i < 100; i++)); do
    kill -0 "$pid" 2>/dev/null || return 0
    sleep 0.1
  done
  echo "$me: $name (pid $pid) still running after 10 s: KILL" >&2
  kill -KILL "$pid" 2>/dev/null || true
}

print_logs() {
  local f
  echo "---- $me: logs ----" >&2
  for f in "$cluster"/log/* "$cluster/munge/munged.log" "$logs"/*; do
    [ -s "$f" ] || continue
    echo "---- $f (last 60 lines)" >&2
    tail -n 60 "$f" >&2 || true
  done
  if [ -n "${SLURM_CONF:-}" ] && [ -n "${ctld_pid:-}" ] && kill -0 "$ctld_pid" 2>/dev/null; then
    echo "---- scontrol show jobs" >&2
    timeout 10 scontrol -o show job >&2 || true
    echo "---- sinfo" >&2
    timeout 10 sinfo -N -l >&2 || true
  fi
}

cleanup() {
  local rc=$? i entry
  trap - EXIT INT TERM
  set +e
  if [ "$rc" -ne 0 ]; then
    print_logs
  fi
  # Jobs first (their slurmstepd outlive slurmd), then the daemons, newest first.
  if [ -n "${ctld_pid:-}" ] && kill -0 "$ctld_pid" 2>/dev/null; then
    timeout 10 scancel --quiet --full --user=root >/dev/null 2>&1
    for ((i = 0; i < 30; i++)); do
      [ -z "$(timeout 10 squeue -h -o %i -t running,completing 2>/dev/null)" ] && break
      sleep 0.5
    done
  fi
  for ((i = ${#daemons[@]} - 1; i >= 0; i--)); do
    entry=${daemons[i]}
    stop_pid "${entry%% *}" "${entry#* }"
  done
  if [ "${VDBSCATTER_SLURM_KEEP:-0}" = 1 ]; then
    echo "$me: kept $tmp" >&2
  else
    rm -rf "$tmp"
  fi
  if [ "$rc" -eq 0 ]; then
    echo "$me: PASS in $((SECONDS - started)) s"
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'echo "$me: interrupted" >&2; exit 130' INT TERM

# wait_for SECONDS WHAT COMMAND...: polls COMMAND every half second until it succeeds, for
# SECONDS at most and not past the test's deadline.
wait_for() {
  local limit=$1 what=$2 t0=$SECONDS end
  shift 2
  end=$((SECONDS + limit))
  [ "$end" -le "$deadline" ] || end=$deadline
  until "$@"; do
    [ "$SECONDS" -lt "$end" ] || fail "timed out after $((SECONDS - t0)) s waiting for $what"
    sleep 0.5
  done
}

# --- the cluster --------------------------------------------------------------------------
step "munged, slurmctld and slurmd in $tmp"
dd if=/dev/urandom of="$cluster/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$cluster/munge/munge.key"
socket=$cluster/munge-socket/munge.socket
munged --foreground --force --socket="$socket" --key-file="$cluster/munge/munge.key" \
  --pid-file="$cluster/munge/munged.pid" --log-file="$cluster/munge/munged.log" \
  --seed-file="$cluster/munge/munged.seed" >"$cluster/log/munged.out" 2>&1 &
daemons+=("munged $!")
munged_pid=$!
munge_ready() {
  kill -0 "$munged_pid" 2>/dev/null || fail "munged exited"
  [ -S "$socket" ]
}
wait_for 30 "munged's socket" munge_ready

# Two free loopback ports (the kernel's choice, so that a second run does not clash).
read -r ctld_port slurmd_port < <(python3 -c '
import socket
socks = [socket.socket() for _ in range(2)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*[s.getsockname()[1] for s in socks])')
host=$(hostname -s 2>/dev/null || uname -n)
host=${host%%.*}
cpus=$(nproc)
cat >"$cluster/slurm.conf" <<EOF
# One node on loopback, written by tests/test_slurm.sh.
ClusterName=vdbstest
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
CommunicationParameters=NoInAddrAny,NoCtldInAddrAny
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$cluster/state
SlurmdSpoolDir=$cluster/spool
SlurmctldPidFile=$cluster/slurmctld.pid
SlurmdPidFile=$cluster/slurmd.pid
SlurmctldLogFile=$cluster/log/slurmctld.log
SlurmdLogFile=$cluster/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
SwitchType=switch/none
ReturnToService=2
MinJobAge=3600
InactiveLimit=0
KillWait=5
SlurmctldTimeout=30
SlurmdTimeout=60
NodeName=$host NodeAddr=127.0.0.1 NodeHostname=$host CPUs=$cpus State=UNKNOWN
PartitionName=vdbstest Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$cluster/slurm.conf

slurmctld -D -i >"$cluster/log/slurmctld.out" 2>&1 &
ctld_pid=$!
daemons+=("slurmctld $ctld_pid")
ctld_up() {
  kill -0 "$ctld_pid" 2>/dev/null || fail "slurmctld exited"
  timeout 10 scontrol ping 2>/dev/null | grep -q 'UP'
}
wait_for 60 "slurmctld to answer" ctld_up

slurmd -D -N "$host" >"$cluster/log/slurmd.out" 2>&1 &
slurmd_pid=$!
daemons+=("slurmd $slurmd_pid")
node_idle() {
  kill -0 "$slurmd_pid" 2>/dev/null || fail "slurmd exited"
  [ "$(timeout 10 sinfo -h -N -n "$host" -o %T 2>/dev/null)" = idle ]
}
wait_for 60 "node $host idle" node_idle
step "cluster up: node $host ($cpus CPUs), slurmctld on 127.0.0.1:$ctld_port, slurmd on :$slurmd_port"

# --- helpers on jobs ------------------------------------------------------------------------
# The records of a job (an array: one per task) as "TASK STATE EXIT" lines; TASK is - for a job
# that is not an array.
job_records() {
  timeout 10 scontrol -o show job "$1" | awk '{
    task = "-"; state = "?"; code = "?"
    for (i = 1; i <= NF; i++) {
      split($i, kv, "=")
      if (kv[1] == "ArrayTaskId") task = substr($i, 13)
      else if (kv[1] == "JobState") state = kv[2]
      else if (kv[1] == "ExitCode") code = kv[2]
    }
    print task, state, code
  }'
}
job_finished() { # every record in a final state
  local records
  records=$(job_records "$1") || return 1
  [ -n "$records" ] || return 1
  ! awk '$2 ~ /^(PENDING|RUNNING|CONFIGURING|COMPLETING|SUSPENDED|REQUEUED|RESIZING|SIGNALING|STAGE_OUT)$/ { found = 1 } END { exit !found }' <<<"$records"
}
submit() { # scripts/slurm_bake.sh ARGS in $work; sets array_job and verify_job
  local out
  out=$(cd "$work" && timeout 120 bash "$src/scripts/slurm_bake.sh" "$@") ||
    fail "scripts/slurm_bake.sh $* exited $?"
  echo "$out"
  array_job=$(sed -n 's/^array_job=\([0-9][0-9]*\) .*/\1/p' <<<"$out")
  verify_job=$(sed -n 's/^verify_job=\([0-9][0-9]*\) .*/\1/p' <<<"$out")
  if [ -z "$array_job" ] || [ -z "$verify_job" ]; then
    fail "no job ids in slurm_bake.sh's output"
  fi
}
json() { # json FILE EXPR: EXPR of the JSON object d of FILE, printed by Python
  python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"
}
frame_file() { # frame_file PREFIX N
  printf '%s.%04d.vdb' "$1" "$2"
}

# --- the bake -------------------------------------------------------------------------------
frames=8
step "$frames sample frames ($vdbscatter sample smoke --res 24)"
for ((f = 1; f <= frames; f++)); do
  timeout 120 "$vdbscatter" sample smoke --res 24 --seed "$f" -q -o "$(frame_file "$work/in" "$f")" ||
    fail "vdbscatter sample for frame $f exited $?"
done
bake_args=("$work/in.####.vdb" -o "$work/out.####.vdb" --frames "1-$frames"
  --method single --quality low --sun "0,-1,0" --backend cpu)
script_args=(--chunk 2 --logs "$logs" --vdbscatter "$vdbscatter" --threads 1)

step "submit: 4 tasks of 2 frames and the verify job"
submit "${script_args[@]}" -- "${bake_args[@]}"
first_array=$array_job
wait_for 300 "array job $array_job and verify job $verify_job" job_finished "$verify_job"
wait_for 30 "array job $array_job to end" job_finished "$array_job"
step "jobs ended: $(job_records "$array_job" | tr '\n' ';') verify: $(job_records "$verify_job")"

records=$(job_records "$array_job" | sort -n)
expected=$(printf '%s COMPLETED 0:0\n' 1 2 3 4)
[ "$records" = "$expected" ] ||
  fail "array job $array_job: tasks (task state exit) $(tr '\n' ';' <<<"$records"), expected 1-4 COMPLETED 0:0"
[ "$(job_records "$verify_job")" = "- COMPLETED 0:0" ] ||
  fail "verify job $verify_job: $(job_records "$verify_job"), expected COMPLETED 0:0"
for ((f = 1; f <= frames; f++)); do
  [ -s "$(frame_file "$work/out" "$f")" ] || fail "no output for frame $f"
done
for t in 1 2 3 4; do
  for ext in out err json; do
    [ -f "$logs/bake_${array_job}_$t.$ext" ] || fail "no $logs/bake_${array_job}_$t.$ext"
  done
  got=$(json "$logs/bake_${array_job}_$t.json" '",".join(str(f) for f in sorted(r["frame"] for r in d["frames"]))')
  [ "$got" = "$((2 * t - 1)),$((2 * t))" ] || fail "task $t baked frames $got, expected its chunk"
  grep -q "frames $((2 * t - 1)),$((2 * t))\$" "$logs/bake_${array_job}_$t.err" ||
    fail "task $t's log does not name its chunk"
done
[ -f "$logs/verify_$verify_job.out" ] || fail "no verify job log"
[ -f "$logs/summary.json" ] || fail "the verify job wrote no summary.json"
[ "$(json "$logs/summary.json" '(d["frames_total"], d["done"], d["failed"], d["missing"])')" = \
  "($frames, $frames, 0, 0)" ] ||
  fail "summary.json: $(json "$logs/summary.json" '{k: d[k] for k in ("frames_total", "done", "skipped", "failed", "missing")}'), expected $frames done"
statuses=$(json "$logs/summary.json" '" ".join(sorted(set(r["status"] for r in d["frames"])))')
[ "$statuses" = up-to-date ] || fail "summary.json: frame statuses '$statuses', expected up-to-date"

# --- one frame lost, its task alone again ---------------------------------------------------
lost=5
task=$(((lost + 1) / 2))
rm "$(frame_file "$work/out" "$lost")"
step "frame $lost deleted: vdbscatter bake --verify exits 3"
rc=0
(cd "$work" && timeout 120 "$vdbscatter" bake "${bake_args[@]}" --verify \
  --summary "$work/verify_lost.json" >"$work/verify_lost.log" 2>&1) || rc=$?
[ "$rc" -eq 3 ] || { cat "$work/verify_lost.log" >&2; fail "--verify with frame $lost gone exited $rc, expected 3"; }
[ "$(json "$work/verify_lost.json" '[(r["frame"], r["status"]) for r in d["frames"] if r["status"] != "up-to-date"]')" = \
  "[($lost, 'missing')]" ] || fail "--verify summary: $(cat "$work/verify_lost.json")"

step "resubmit task $task alone (--tasks $task)"
rm "$logs/summary.json"
submit "${script_args[@]}" --tasks "$task" -- "${bake_args[@]}"
wait_for 300 "array job $array_job and verify job $verify_job" job_finished "$verify_job"
wait_for 30 "array job $array_job to end" job_finished "$array_job"
[ "$(job_records "$array_job")" = "$task COMPLETED 0:0" ] ||
  fail "rerun array job $array_job: $(job_records "$array_job" | tr '\n' ';'), expected task $task alone, COMPLETED 0:0"
[ "$(job_records "$verify_job")" = "- COMPLETED 0:0" ] ||
  fail "second verify job $verify_job: $(job_records "$verify_job"), expected COMPLETED 0:0"
[ -s "$(frame_file "$work/out" "$lost")" ] || fail "frame $lost was not baked again"
for ext in out err json; do
  [ -f "$logs/bake_${array_job}_$task.$ext" ] || fail "no $logs/bake_${array_job}_$task.$ext"
done
n_logs=$(find "$logs" -name "bake_${array_job}_*.out" | wc -l)
[ "$n_logs" -eq 1 ] || fail "the rerun left $n_logs task logs, expected 1"
[ "$(json "$logs/bake_${array_job}_$task.json" 'sorted((r["frame"], r["status"]) for r in d["frames"])')" = \
  "[($lost, 'baked'), ($((lost + 1)), 'up-to-date')]" ] ||
  fail "rerun task $task: $(cat "$logs/bake_${array_job}_$task.json"), expected frame $lost baked and $((lost + 1)) up to date"
[ -f "$logs/summary.json" ] || fail "the second verify job wrote no summary.json"
[ "$(json "$logs/summary.json" '(d["frames_total"], d["done"], d["failed"], d["missing"])')" = \
  "($frames, $frames, 0, 0)" ] || fail "summary.json after the rerun: $(cat "$logs/summary.json")"
n_logs=$(find "$logs" -name "bake_${first_array}_*.out" | wc -l)
[ "$n_logs" -eq 4 ] || fail "the first array's logs: $n_logs, expected 4"
step "task $task rerun: frame $lost baked again, verify passes"
