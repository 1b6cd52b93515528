#!/usr/bin/env bash
# Configures and builds Sweep (Release, warnings as errors) into ./build.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/install-deps.sh"
cmake -S . -B build -DCMAKE_BUILD_TYPE="${SWEEP_BUILD_TYPE:-Release}" -DSWEEP_WERROR=ON >/dev/null
cmake --build build -j "$(nproc)"
