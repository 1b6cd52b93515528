#!/usr/bin/env bash
# The main job: installs the dependencies, builds Sweep, and runs the Hall funnel with both
# schemes (results, bench table and the seed's Figures 1-3 in results/funnel/).
set -euo pipefail
cd "$(dirname "$0")/.."
# the job runs the `sweep` tool only: the tests, benchmarks and examples are not built here
./scripts/build.sh sweep_cli
./examples/funnel/make_figures.sh results/funnel "$@"
