#!/usr/bin/env bash
# Builds Sweep with AddressSanitizer and UndefinedBehaviorSanitizer (GCC, -O1, every target
# instrumented) into ./build-asan and runs the whole test suite there, but for the Python
# module's tests (an instrumented module cannot load into an uninstrumented interpreter). Any
# sanitizer report fails the run: errors are not recoverable (-fno-sanitize-recover) and leaks
# are checked.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh"
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSWEEP_SANITIZE=address,undefined \
  -DSWEEP_BUILD_BENCHMARKS=OFF -DSWEEP_BUILD_PYTHON=OFF -DSWEEP_WERROR=ON >/dev/null
cmake --build build-asan -j "$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# the two million-step tests (label long) are left to the normal suite: too slow instrumented
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -LE long
