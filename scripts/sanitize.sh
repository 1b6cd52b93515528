#!/usr/bin/env bash
# Builds Sweep with AddressSanitizer and UndefinedBehaviorSanitizer (GCC, -O1, every target
# instrumented) into ./build-asan and runs the test suite there, but for the Python module's
# tests (an instrumented module cannot load into an uninstrumented interpreter), the
# million-step runs (label long) and the validation studies (label study), which the normal
# suite runs. Any sanitizer report fails the run: errors are not recoverable
# (-fno-sanitize-recover) and leaks are checked.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh"
# -O1 -g1: line tables are all a report needs, and a file compiles in half the time of -O2 -g
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DSWEEP_SANITIZE=address,undefined \
  -DSWEEP_BUILD_BENCHMARKS=OFF -DSWEEP_BUILD_EXAMPLES=OFF -DSWEEP_BUILD_PYTHON=OFF \
  -DSWEEP_WERROR=ON >/dev/null
cmake --build build-asan -j "$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -LE "long|study"
