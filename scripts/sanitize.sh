#!/usr/bin/env bash
# Builds Sweep with AddressSanitizer and UndefinedBehaviorSanitizer (GCC, -O2 -g1, every
# target instrumented) into ./build-asan and runs the test suite there, but for the Python module's
# tests (an instrumented module cannot load into an uninstrumented interpreter), the
# million-step runs (label long), the studies (label study) and the threads test (label
# threads: its loops are the ones the unit tests' threaded cases run here, and it runs under
# ThreadSanitizer), which the normal suite runs. Any sanitizer report fails the run: errors are not recoverable
# (-fno-sanitize-recover) and leaks are checked.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh"
# -g1: line tables are all a report needs, and a file compiles in two thirds of the time of
# -g. -O2, not -O1: -O1 compiles a quarter faster, but the instrumented tests ran up to 1.4
# times as long (docs/robustness.md, "CI time")
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DSWEEP_SANITIZE=address,undefined \
  -DSWEEP_BUILD_BENCHMARKS=OFF -DSWEEP_BUILD_EXAMPLES=OFF -DSWEEP_BUILD_PYTHON=OFF \
  -DSWEEP_BUILD_STUDY_TESTS=OFF -DSWEEP_WERROR=ON >/dev/null
cmake --build build-asan -j "$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -LE "long|study|threads"
