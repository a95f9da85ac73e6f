#!/usr/bin/env bash
# Builds the libFuzzer harnesses of fuzz/ with clang (build-fuzz/, ccache when installed) and
# runs each for SECONDS (default 30), as many at once as there are cores (VDBSCATTER_FUZZ_JOBS
# sets another number), from the committed
# seeds, samples/, the external test data when present (VDBSCATTER_DATA_DIR, else
# ../shared/data) and the corpus of earlier runs (fuzz/corpus/, not committed). Prints per
# harness the executions per second, the corpus size and the findings (fuzz/findings/HARNESS/);
# exits 1 on any finding, 3 when the build fails. A finding is fixed in the code and its input kept in
# fuzz/regressions/HARNESS/ (replayed by the ctest fuzz_replay_HARNESS). docs/robustness.md.
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-30}
case "$secs" in '' | *[!0-9]*) echo "usage: scripts/fuzz.sh [SECONDS]" >&2; exit 2 ;; esac
root=$PWD
harnesses=(vdb exr hdr scene obj cli lit)
data_dir=${VDBSCATTER_DATA_DIR:-$root/../shared/data}

launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
start=$SECONDS
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Fuzz -DVDBSCATTER_FUZZ=ON \
  "${launcher[@]}" >/dev/null
cmake --build build-fuzz -j "$(nproc)" 2>&1 | grep -E "error|FAILED" && exit 3
echo "fuzz.sh: built in $((SECONDS - start)) s"

# Seeds, gathered per harness into build-fuzz/seeds/HARNESS (libFuzzer reads folders).
seeds=$root/build-fuzz/seeds
rm -rf "$seeds"
add_seeds() { # HARNESS MAX_BYTES FILES...
  local h=$1 max=$2; shift 2
  mkdir -p "$seeds/$h"
  for f in "$@"; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le "$max" ] && cp "$f" "$seeds/$h/"
  done
  return 0
}
shopt -s nullglob
for h in "${harnesses[@]}"; do add_seeds "$h" 1000000 fuzz/seeds/"$h"/* fuzz/regressions/"$h"/*; done
add_seeds vdb 300000 samples/*.vdb "$data_dir"/*.vdb
add_seeds lit 300000 samples/*.vdb
add_seeds exr 300000 samples/*.exr
add_seeds scene 100000 samples/*.json
add_seeds obj 100000 samples/*.obj

run_one() { # HARNESS
  local h=$1 corpus=$root/fuzz/corpus/$1 findings=$root/fuzz/findings/$1 work
  work=$(mktemp -d)
  mkdir -p "$corpus" "$findings"
  # allocator_may_return_null: an absurd size read from a hostile file is refused
  # (bad_alloc), which the readers report, instead of being a sanitizer finding.
  (cd "$work" && TMPDIR=$work ASAN_OPTIONS=allocator_may_return_null=1:detect_leaks=1 \
    UBSAN_OPTIONS=print_stacktrace=1 \
    "$root/build-fuzz/fuzz/fuzz_$h" "$corpus" "$seeds/$h" -max_total_time="$secs" \
    -max_len=300000 -timeout=60 -rss_limit_mb=4096 -malloc_limit_mb=65536 \
    -report_slow_units=1000 -print_final_stats=1 \
    -artifact_prefix="$findings/" >"$root/build-fuzz/fuzz_$h.log" 2>&1) || true
  rm -rf "$work"
}
export -f run_one
export root secs seeds
jobs=${VDBSCATTER_FUZZ_JOBS:-$(nproc)}
case "$jobs" in '' | *[!0-9]* | 0) echo "fuzz.sh: VDBSCATTER_FUZZ_JOBS must be a count" >&2; exit 2 ;; esac
printf '%s\n' "${harnesses[@]}" | xargs -P "$jobs" -I{} bash -c 'run_one {}'

status=0
printf '%-6s %10s %8s %8s %9s\n' harness execs execs/s corpus findings
for h in "${harnesses[@]}"; do
  log=build-fuzz/fuzz_$h.log
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  corpus=$(find "fuzz/corpus/$h" -type f | wc -l)
  found=$(find "fuzz/findings/$h" -type f ! -name 'slow-unit-*' | wc -l)
  printf '%-6s %10s %8s %8s %9s\n' "$h" "${execs:-?}" "${rate:-?}" "$corpus" "$found"
  if [ "$found" -gt 0 ] || [ -z "$execs" ]; then
    status=1
    echo "  $log:"; { grep -E "ERROR|SUMMARY|fuzz:|Test unit written|exiting" "$log" || true; } | head -5 | sed "s/^/    /"
    find "fuzz/findings/$h" -type f ! -name 'slow-unit-*' | sed 's/^/    finding: /'
  fi
done
echo "fuzz.sh: done in $((SECONDS - start)) s"
exit $status
