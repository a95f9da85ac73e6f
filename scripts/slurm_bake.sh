#!/usr/bin/env bash
# Bakes a frame sequence on a Slurm cluster: one array task per chunk of frames, each running
# `vdbscatter bake ... --frames CHUNK`, then a verify job (after all the tasks, whatever their
# end) that runs `vdbscatter bake ... --verify --summary LOGS/summary.json`.
# docs/farm.md is the recipe; `scripts/slurm_bake.sh --help` the options.
set -euo pipefail

me=slurm_bake
usage() {
  cat <<'EOF'
usage: scripts/slurm_bake.sh [options] -- BAKE_ARGS...

Submits `vdbscatter bake BAKE_ARGS` to Slurm as a job array, one task per chunk of
the frames of BAKE_ARGS' --frames (required: A, A-B, A-BxSTEP, comma lists), and a
verify job that runs after the array (afterany) with the same words plus --verify
--summary LOGS/summary.json; it exits 0 when every frame is up to date, 3 if not.
Task i (from 1) bakes the i-th chunk of the sorted frame list. Bakes are resumable:
rerunning a task bakes only the frames whose output is missing or stale.

options:
  --chunk N            frames per array task (default 10)
  --logs DIR           per-task logs (bake_%A_%a.out/.err), per-task summaries
                       (bake_%A_%a.json), the verify job's log (verify_%j.out/.err),
                       summary.json and the generated batch scripts (default slurm-logs)
  --threads N          CPUs per task (sbatch --cpus-per-task) and bake --threads; without
                       it, BAKE_ARGS' --threads N sets --cpus-per-task, else 1 CPU; bake is
                       given --threads $SLURM_CPUS_PER_TASK unless BAKE_ARGS has --threads
  --max-running N      at most N array tasks running at once (--array=...%N)
  --sbatch-args "..."  more sbatch options for both jobs, split on spaces (partition,
                       account, --time, --mem); they come last, so they override ours
  --vdbscatter PATH    the vdbscatter the jobs run (default: the one on PATH here)
  --tasks LIST         submit only these array tasks (e.g. 3 or 2,5-7) with their
                       chunks, then a new verify job; give the same other arguments as
                       the first submission so that the chunks are the same
  --dry-run            print the sbatch command lines and batch scripts, submit nothing
  -h, --help           this help

Prints on stdout:
  array_job=ID tasks=LIST frames=N chunk=N logs=DIR
  verify_job=ID summary=DIR/summary.json
Exit status: 0 submitted, 1 sbatch failed, 2 bad usage.
EOF
}

die() {
  echo "$me: $*" >&2
  exit 2
}

# The integers of a list "A", "A-B", "A-BxS" (x only where allowed), comma-separated, one a
# line in the order written. $1: the list, $2: its name for messages, $3: "x" to allow steps.
expand_list() {
  local text=$1 what=$2 steps=$3 item a b s n
  local re='^([0-9]+)(-([0-9]+))?$'
  [ "$steps" = x ] && re='^([0-9]+)(-([0-9]+)(x([0-9]+))?)?$'
  [ -n "$text" ] || die "$what: empty"
  case "$text" in
    ,* | *, | *,,*) die "$what: empty item in '$text'" ;;
  esac
  local -a items
  IFS=, read -ra items <<<"$text"
  for item in "${items[@]}"; do
    [[ $item =~ $re ]] || die "$what: bad item '$item' (A, A-B$([ "$steps" = x ] && echo ", A-BxSTEP"))"
    if [ ${#BASH_REMATCH[1]} -gt 9 ] || [ ${#BASH_REMATCH[3]} -gt 9 ]; then
      die "$what: number too large in '$item'"
    fi
    a=$((10#${BASH_REMATCH[1]}))
    b=$a
    s=1
    [ -n "${BASH_REMATCH[3]}" ] && b=$((10#${BASH_REMATCH[3]}))
    if [ "$steps" = x ] && [ -n "${BASH_REMATCH[5]}" ]; then
      [ ${#BASH_REMATCH[5]} -le 9 ] || die "$what: step too large in '$item'"
      s=$((10#${BASH_REMATCH[5]}))
    fi
    [ "$s" -ge 1 ] || die "$what: step must be at least 1 in '$item'"
    [ "$b" -ge "$a" ] || die "$what: range backwards in '$item'"
    for ((n = a; n <= b; n += s)); do
      echo "$n"
    done
  done
}

# Part of a sorted array of integers written compactly into $compacted: runs of 3 or more
# with one step as A-B or (with $2 = x) A-BxS, the rest comma-separated. $1: the array's
# name, $2: "x" or "", $3, $4: the first index and the count. No subshell: a chunk list of
# thousands of frames is written in a blink.
compact() {
  local -n v=$1
  local steps=$2 i=$3 last=$(($3 + $4)) j d
  [ "$last" -le ${#v[@]} ] || last=${#v[@]}
  compacted=""
  while [ "$i" -lt "$last" ]; do
    j=$i
    d=1
    if [ $((i + 1)) -lt "$last" ]; then
      d=$((v[i + 1] - v[i]))
      if [ "$d" -eq 1 ] || [ "$steps" = x ]; then
        while [ $((j + 1)) -lt "$last" ] && [ $((v[j + 1] - v[j])) -eq "$d" ]; do
          j=$((j + 1))
        done
      fi
    fi
    if [ $((j - i)) -ge 2 ] || { [ $((j - i)) -eq 1 ] && [ "$d" -eq 1 ] && [ "$steps" != x ]; }; then
      if [ "$d" -eq 1 ]; then
        compacted+=",${v[i]}-${v[j]}"
      else
        compacted+=",${v[i]}-${v[j]}x$d"
      fi
      i=$((j + 1))
    else
      compacted+=",${v[i]}"
      i=$((i + 1))
    fi
  done
  compacted=${compacted#,}
}

positive() { # $1 name, $2 value
  [[ $2 =~ ^[1-9][0-9]{0,5}$ ]] || die "$1: expected a positive integer, got '$2'"
}

chunk=10
logs=slurm-logs
threads=""
max_running=""
sbatch_extra=""
vdbscatter=""
tasks_arg=""
dry_run=0
while [ $# -gt 0 ]; do
  case "$1" in
    -h | --help)
      usage
      exit 0
      ;;
    --chunk | --logs | --threads | --max-running | --sbatch-args | --vdbscatter | --tasks)
      [ $# -ge 2 ] || die "$1 needs a value"
      case "$1" in
        --chunk) chunk=$2 ;;
        --logs) logs=$2 ;;
        --threads) threads=$2 ;;
        --max-running) max_running=$2 ;;
        --sbatch-args) sbatch_extra=$2 ;;
        --vdbscatter) vdbscatter=$2 ;;
        --tasks) tasks_arg=$2 ;;
      esac
      shift 2
      ;;
    --chunk=* | --logs=* | --threads=* | --max-running=* | --sbatch-args=* | --vdbscatter=* | --tasks=*)
      set -- "${1%%=*}" "${1#*=}" "${@:2}"
      ;;
    --dry-run)
      dry_run=1
      shift
      ;;
    --)
      shift
      break
      ;;
    *) die "unknown option '$1' (the bake's words come after --; see --help)" ;;
  esac
done
[ $# -gt 0 ] || die "no bake arguments after -- (see --help)"
positive --chunk "$chunk"
[ -z "$threads" ] || positive --threads "$threads"
[ -z "$max_running" ] || positive --max-running "$max_running"
[ -n "$logs" ] || die "--logs: empty"

# The bake's words: --frames and --threads come out (each task gets its own), --verify and
# --summary are this script's to give.
frames_text=""
bake_threads=""
bake=()
while [ $# -gt 0 ]; do
  case "$1" in
    --frames | --threads)
      [ $# -ge 2 ] || die "bake $1 needs a value"
      if [ "$1" = --frames ]; then frames_text=$2; else bake_threads=$2; fi
      shift 2
      ;;
    --frames=*)
      frames_text=${1#*=}
      shift
      ;;
    --threads=*)
      bake_threads=${1#*=}
      shift
      ;;
    --verify | --summary | --summary=*)
      die "bake ${1%%=*} is this script's to give (the verify job); leave it out"
      ;;
    *)
      bake+=("$1")
      shift
      ;;
  esac
done
[ -n "$frames_text" ] || die "the bake arguments need --frames (e.g. --frames 1-240)"
if [ -n "$bake_threads" ]; then
  positive "bake --threads" "$bake_threads"
  [ -z "$threads" ] || [ "$threads" = "$bake_threads" ] ||
    die "--threads $threads and bake --threads $bake_threads differ: give one"
  threads=$bake_threads
fi
cpus=${threads:-1}

expanded=$(expand_list "$frames_text" --frames x) || exit 2
mapfile -t frames < <(sort -n -u <<<"$expanded")
[ ${#frames[@]} -gt 0 ] || die "--frames: no frames in '$frames_text'"
ntasks=$(((${#frames[@]} + chunk - 1) / chunk))
compact frames x 0 ${#frames[@]}
all_frames=$compacted

if [ -n "$tasks_arg" ]; then
  expanded=$(expand_list "$tasks_arg" --tasks "") || exit 2
  mapfile -t tasks < <(sort -n -u <<<"$expanded")
  for t in "${tasks[@]}"; do
    if [ "$t" -lt 1 ] || [ "$t" -gt "$ntasks" ]; then
      die "--tasks: no task $t: $ntasks tasks of $chunk frames (same --chunk and --frames as the first submission?)"
    fi
  done
else
  tasks=()
  for ((t = 1; t <= ntasks; t++)); do tasks+=("$t"); done
fi
compact tasks "" 0 ${#tasks[@]}
array=$compacted

if [ -z "$vdbscatter" ]; then
  vdbscatter=$(command -v vdbscatter || true)
  if [ -z "$vdbscatter" ]; then
    [ "$dry_run" -eq 1 ] || die "no vdbscatter on PATH; give --vdbscatter PATH"
    vdbscatter=vdbscatter
  fi
fi
case "$logs" in
  /*) ;;
  *) logs=$PWD/$logs ;;
esac
read -ra sbatch_more <<<"$sbatch_extra"

quoted_bake=$(printf ' %q' "$vdbscatter" bake "${bake[@]}")
# shellcheck disable=SC2016 # expanded by the task, not here
threads_words=' --threads "${SLURM_CPUS_PER_TASK:-1}"'

# The array's batch script: each task's chunk by its index.
bake_script="#!/bin/bash
# Written by scripts/slurm_bake.sh: ${#frames[@]} frames ($all_frames), $ntasks tasks of $chunk.
set -u
case \"\${SLURM_ARRAY_TASK_ID:?not a Slurm array task}\" in"
for ((t = 1; t <= ntasks; t++)); do
  compact frames x $(((t - 1) * chunk)) "$chunk"
  bake_script+="
  $t) frames=$compacted ;;"
done
bake_script+="
  *) echo \"slurm_bake: no chunk for task \$SLURM_ARRAY_TASK_ID\" >&2; exit 2 ;;
esac
echo \"slurm_bake: job \${SLURM_ARRAY_JOB_ID}_\$SLURM_ARRAY_TASK_ID on \$(hostname): frames \$frames\" >&2
exec$quoted_bake --frames \"\$frames\"$threads_words --summary $(printf %q "$logs")/\"bake_\${SLURM_ARRAY_JOB_ID}_\$SLURM_ARRAY_TASK_ID.json\"
"

verify_script="#!/bin/bash
# Written by scripts/slurm_bake.sh: checks every frame's output after the array, with the
# tasks' words (--threads included) but for --frames, --verify and --summary.
exec$quoted_bake --frames $all_frames$threads_words --verify --summary $(printf %q "$logs/summary.json")
"

array_spec=$array${max_running:+%$max_running}
array_cmd=(sbatch --parsable --job-name=vdbscatter-bake "--array=$array_spec"
  "--cpus-per-task=$cpus" "--chdir=$PWD"
  "--output=$logs/bake_%A_%a.out" "--error=$logs/bake_%A_%a.err"
  "${sbatch_more[@]}" "$logs/bake.sbatch")
verify_cmd=(sbatch --parsable --job-name=vdbscatter-verify "--cpus-per-task=$cpus" "--chdir=$PWD"
  "--output=$logs/verify_%j.out" "--error=$logs/verify_%j.err"
  "${sbatch_more[@]}" "$logs/verify.sbatch")

if [ "$dry_run" -eq 1 ]; then
  printf '# %s/bake.sbatch\n%s\n# %s/verify.sbatch\n%s\n' "$logs" "$bake_script" "$logs" "$verify_script"
  printf '%q ' "${array_cmd[@]}"
  echo
  printf '%q ' "${verify_cmd[@]:0:2}" "--dependency=afterany:ARRAY_JOB" "${verify_cmd[@]:2}"
  echo
  echo "array_job=DRY-RUN tasks=$array frames=${#frames[@]} chunk=$chunk logs=$logs"
  echo "verify_job=DRY-RUN summary=$logs/summary.json"
  exit 0
fi

command -v sbatch >/dev/null || die "no sbatch on PATH (Slurm's client commands are needed)"
mkdir -p "$logs"
printf '%s' "$bake_script" >"$logs/bake.sbatch"
printf '%s' "$verify_script" >"$logs/verify.sbatch"

submitted=$("${array_cmd[@]}") || {
  echo "$me: sbatch of the array failed" >&2
  exit 1
}
array_job=${submitted%%;*}
echo "array_job=$array_job tasks=$array frames=${#frames[@]} chunk=$chunk logs=$logs"
submitted=$("${verify_cmd[@]:0:2}" "--dependency=afterany:$array_job" "${verify_cmd[@]:2}") || {
  echo "$me: sbatch of the verify job failed (the array $array_job is submitted)" >&2
  exit 1
}
verify_job=${submitted%%;*}
echo "verify_job=$verify_job summary=$logs/summary.json"
echo "$me: squeue -j $array_job,$verify_job to follow; logs in $logs" >&2
