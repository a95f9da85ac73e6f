#!/usr/bin/env bash
# Sets up, builds with warnings as errors and runs the whole test suite, then builds
# again with AddressSanitizer + UndefinedBehaviorSanitizer and runs it once more
# (statistical tests skipped there; GL tests without leak checks: Mesa's EGL leaks at exit).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
jobs=$(nproc)

cmake -S . -B build-ci -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVDBSCATTER_WERROR=ON
cmake --build build-ci -j "$jobs"
ctest --test-dir build-ci --output-on-failure -j "$jobs"

cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DVDBSCATTER_WERROR=ON -DVDBSCATTER_SANITIZE=ON
cmake --build build-asan -j "$jobs"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ASAN_OPTIONS=detect_leaks=1 ctest --test-dir build-asan --output-on-failure -j "$jobs" -L unit -LE "statistical"
ASAN_OPTIONS=detect_leaks=0 ctest --test-dir build-asan --output-on-failure -j "$jobs" -L "gl|cli" -LE "statistical"
