#!/usr/bin/env bash
# Configures ./build-asan, the one tree of the AddressSanitizer + UndefinedBehaviorSanitizer
# suite (scripts/sanitize.sh) and of the fuzzers (scripts/fuzz.sh), and builds the given
# targets in it (default: all). clang 14: it compiles an instrumented file in half the time GCC
# takes, and libFuzzer is clang's. Sweep's libraries also carry libFuzzer's coverage
# instrumentation (SWEEP_FUZZ; CMakeLists.txt says how much where), so that the fuzzers and the
# tests share one build.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh" --clang
# -g1: line tables are all a report needs, and a file compiles in two thirds of the time of
# -g. -O2, not -O1: -O1 compiles a quarter faster, but the instrumented tests ran up to 1.4
# times as long (docs/robustness.md, "CI time")
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DSWEEP_FUZZ=ON \
  -DSWEEP_BUILD_BENCHMARKS=OFF -DSWEEP_BUILD_EXAMPLES=OFF -DSWEEP_BUILD_PYTHON=OFF \
  -DSWEEP_BUILD_STUDY_TESTS=OFF -DSWEEP_WERROR=ON >/dev/null
targets=()
[ $# -eq 0 ] || targets=(--target "$@")
cmake --build build-asan -j "$(nproc)" "${targets[@]}"
