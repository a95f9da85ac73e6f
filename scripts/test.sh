#!/usr/bin/env bash
# Sets up, builds with warnings as errors and runs the whole test suite, then builds
# again with AddressSanitizer + UndefinedBehaviorSanitizer and runs it once more
# (statistical tests skipped there; GL tests without leak checks: Mesa's EGL leaks at exit).
# --long also runs the tests labelled "long" (minutes each; tests/CMakeLists.txt lists them).
# Tests labelled "heavy" run in the normal pass only.
set -euo pipefail
cd "$(dirname "$0")/.."
skip_long=(-LE long)
for arg in "$@"; do
  case "$arg" in
    --long) skip_long=() ;;
    *) echo "usage: scripts/test.sh [--long]" >&2; exit 2 ;;
  esac
done
bash scripts/setup.sh
jobs=$(nproc)
# One OpenMP thread per test: ctest runs a test per core already, and OpenMP's barriers spin
# while they wait, so two tests of two threads each on two cores wait on each other's
# descheduled threads (the extremes slice: 9-16 s alone, 73-85 s for two at once; 13-15 s for
# two of one thread each). The tests about thread counts set their own (test_determinism_cli, and
# omp_set_num_threads in the statistical tests). A value already set is kept.
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"

# Without the external test data beside the clone (../shared/data), the tests that read it
# skip themselves; name them once per build, from ctest's log.
report_skipped() {
  [ -f ../shared/data/README.md ] && return 0
  local log="$1/Testing/Temporary/LastTest.log"
  echo "test.sh: no external test data in ../shared/data; these tests were skipped:"
  awk '/^[0-9]+\/[0-9]+ Test: / { test = $3 }
       /^\[  SKIPPED \] [A-Za-z_]/ { print "  " test ": " $4 }
       / \.\.\. skipped / { sub(/^.*\(__main__\./, ""); sub(/\).*$/, ""); print "  " test ": " $0 }' \
    "$log" 2>/dev/null | sort -u || true
}

cmake -S . -B build-ci -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVDBSCATTER_WERROR=ON
cmake --build build-ci -j "$jobs"
ctest --test-dir build-ci --output-on-failure -j "$jobs" "${skip_long[@]}"
report_skipped build-ci

cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DVDBSCATTER_WERROR=ON -DVDBSCATTER_SANITIZE=ON
cmake --build build-asan -j "$jobs"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ASAN_OPTIONS=detect_leaks=1 ctest --test-dir build-asan --output-on-failure -j "$jobs" -L unit -LE "statistical|long|heavy"
ASAN_OPTIONS=detect_leaks=0 ctest --test-dir build-asan --output-on-failure -j "$jobs" -L "gl|cli" -LE "statistical|long|heavy"

# libFuzzer: every harness of fuzz/ for 30 s, all at once, sharing the cores (a 30 s sample
# either way; one at a time per core it took four times as long; docs/robustness.md "Fuzzing").
# A failed fuzz build fails the run; a finding is listed with its input but does not: 30 s of
# random inputs is a sample, not a gate, and a forked reader's timeout is not yet told apart
# from a hang. Each finding, once fixed, is kept under fuzz/regressions/, which the replay
# tests above gate in both passes.
fuzz_rc=0
VDBSCATTER_FUZZ_JOBS=7 bash scripts/fuzz.sh 30 || fuzz_rc=$?
if [ "$fuzz_rc" -eq 1 ]; then
  echo "test.sh: the fuzz run reported findings (listed above; inputs in fuzz/findings/)"
elif [ "$fuzz_rc" -ne 0 ]; then
  exit "$fuzz_rc"
fi
