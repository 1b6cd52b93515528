#!/usr/bin/env bash
# The main job: builds Sweep and runs the headline example.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh
./build/examples/double_pendulum/double_pendulum_demo "$@"
