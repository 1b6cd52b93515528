#!/usr/bin/env bash
# Builds Sweep with ThreadSanitizer (clang, with LLVM's OpenMP runtime and its Archer tool,
# which tells ThreadSanitizer about OpenMP's barriers and tasks) into ./build-tsan and runs
# the test suite there, but for the long tests and the Python module's (an instrumented
# module cannot load into an uninstrumented interpreter). Any data race fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh" --clang
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DSWEEP_SANITIZE=thread -DSWEEP_BUILD_BENCHMARKS=OFF \
  -DSWEEP_BUILD_PYTHON=OFF -DSWEEP_WERROR=ON >/dev/null
cmake --build build-tsan -j "$(nproc)"
export OMP_TOOL_LIBRARIES=/usr/lib/llvm-14/lib/libarcher.so
# threads wait for a barrier asleep, not spinning: the threads test runs 4 threads on a 2-core
# machine beside another test, and spinning threads under ThreadSanitizer starve the others
export OMP_WAIT_POLICY=passive
export TSAN_OPTIONS="halt_on_error=1 ignore_noninstrumented_modules=1"
# the threads of the uninstrumented BLAS under CHOLMOD are not Sweep's: one is enough here
export OPENBLAS_NUM_THREADS=1
ctest --test-dir build-tsan --output-on-failure -j "$(nproc)" -LE long
