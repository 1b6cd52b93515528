#!/usr/bin/env bash
# Builds Sweep with AddressSanitizer and UndefinedBehaviorSanitizer (clang, -O2 -g1, every
# target instrumented; scripts/asan-tree.sh) into ./build-asan and runs the test suite there,
# but for the Python module's tests (an instrumented module cannot load into an uninstrumented
# interpreter), the million-step runs (label long), the studies (label study) and the threads
# test (label threads: its loops are the ones the unit tests' threaded cases run here, and it
# runs under ThreadSanitizer), which the normal suite runs. Any sanitizer report fails the run:
# errors are not recoverable (-fno-sanitize-recover) and leaks are checked.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/asan-tree.sh
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# the solvers' same-bits tests compare 1 and 2 threads here (the threaded paths' memory use);
# the normal suite compares 1 to 4
export SWEEP_TEST_THREAD_COUNTS=1,2
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -LE "long|study|threads"
