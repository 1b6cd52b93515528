#!/usr/bin/env bash
# Configures and builds Sweep (Release, warnings as errors) into ./build. Usage:
#   scripts/build.sh [TARGET ...]     (default: every target: library, tool, tests, benchmarks)
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh"
cmake -S . -B build -DCMAKE_BUILD_TYPE="${SWEEP_BUILD_TYPE:-Release}" -DSWEEP_WERROR=ON >/dev/null
targets=()
[ $# -eq 0 ] || targets=(--target "$@")
cmake --build build -j "$(nproc)" "${targets[@]}"
