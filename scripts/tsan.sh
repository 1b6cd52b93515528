#!/usr/bin/env bash
# Builds Sweep with ThreadSanitizer (clang, with LLVM's OpenMP runtime and its Archer tool,
# which tells ThreadSanitizer about OpenMP's barriers and tasks) into ./build-tsan and runs the
# tests that start threads there. Any data race fails the run.
#
# ThreadSanitizer can only see a race where two threads run, and Sweep's loops go parallel
# only from kParallelItems items on (framework/parallel.hpp): the other tests run on one
# thread and would only be slower here. These are the ones that drive the threaded code
# (docs/robustness.md, "Sanitizers"): app.threads.* (every threaded loop of a step: coloured
# sweeps, detection, screening, body trees, the assembly), detection, the coloured sweeps, the
# Newton solver's split factorization and two solves at once. Only their executables and the
# sweep command are built. The normal suite runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh" --clang
# -g1: line tables are all a report needs, and a file compiles in two thirds of the time of
# -g. -O2, not -O1: -O1 compiles a quarter faster, but the instrumented tests ran up to 1.4
# times as long (docs/robustness.md, "CI time")
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
  -DSWEEP_SANITIZE=thread -DSWEEP_BUILD_BENCHMARKS=OFF -DSWEEP_BUILD_EXAMPLES=OFF \
  -DSWEEP_BUILD_PYTHON=OFF -DSWEEP_WERROR=ON >/dev/null
cmake --build build-tsan -j "$(nproc)" --target sweep_cli integrators_tests contact_tests
export OMP_TOOL_LIBRARIES=/usr/lib/llvm-14/lib/libarcher.so
# threads wait for a barrier asleep, not spinning: the threads test runs 4 threads on a 2-core
# machine beside another test, and spinning threads under ThreadSanitizer starve the others
export OMP_WAIT_POLICY=passive
export TSAN_OPTIONS="halt_on_error=1 ignore_noninstrumented_modules=1"
# the threads of the uninstrumented BLAS under CHOLMOD are not Sweep's: one is enough here
export OPENBLAS_NUM_THREADS=1
# the threads tests (the app's and the solvers' same-bits tests) compare 2 and 4 threads here: a
# race needs two, and the 1-thread runs, as costly under ThreadSanitizer, are compared in the
# normal suite
export SWEEP_TEST_THREAD_COUNTS=2,4
threaded='^app\.threads\.|Thread|TwoSolvesAtOnce|ColouredSweeps|LargeProgramsOfAnyGraphShape'
ctest --test-dir build-tsan --output-on-failure -j "$(nproc)" -R "$threaded" -LE long
