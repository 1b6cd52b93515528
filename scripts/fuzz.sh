#!/usr/bin/env bash
# Fuzzes the scene parser, the URDF importer, saved states and the viewer's snapshot reader
# with libFuzzer (clang), under AddressSanitizer
# and UndefinedBehaviorSanitizer. Usage:
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET ...]  (default: 60 s, scene, settings, snapshot, state, urdf)
# The seed corpus is every scene and URDF of examples/ and tests/data/, the saved states and
# snapshots of tests/fuzz/seeds/, plus the inputs that once crashed Sweep (tests/fuzz/regressions/,
# replayed first). The YAML targets mutate with tests/fuzz/scene.dict (the parser's keys). A crash leaves its input in
# build-fuzz/crash-* and makes this script fail; add the input to tests/fuzz/regressions/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scene settings snapshot state urdf)

"./scripts/install-deps.sh" --clang
# -O2 -g1 as in the sanitizer suites (scripts/sanitize.sh)
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DSWEEP_FUZZ=ON -DSWEEP_BUILD_TESTS=OFF \
  -DSWEEP_BUILD_BENCHMARKS=OFF -DSWEEP_BUILD_EXAMPLES=OFF -DSWEEP_WERROR=ON >/dev/null
cmake --build build-fuzz -j "$(nproc)" --target "${targets[@]/%/_fuzzer}"

for target in "${targets[@]}"; do
  corpus="build-fuzz/corpus/$target"
  mkdir -p "$corpus"
  case "$target" in
    # a scene file is a settings file too: its top-level keys are paths
    scene | settings) find examples tests/data/scenes -name '*.yaml' -exec cp {} "$corpus/" \; ;;
    urdf) find examples tests/data -name '*.urdf' -exec cp {} "$corpus/" \; ;;
    state | snapshot) cp "tests/fuzz/seeds/$target"/* "$corpus/" ;;
  esac
  dictionary=()
  case "$target" in scene | settings) dictionary=(-dict=../tests/fuzz/scene.dict) ;; esac
  echo "fuzz: $target for $seconds s"
  # the regressions replay first: libFuzzer runs every given corpus before mutating (a target
  # that never broke has no folder, and libFuzzer refuses a folder that does not exist)
  regressions=()
  [ -d "tests/fuzz/regressions/$target" ] && regressions=("../tests/fuzz/regressions/$target")
  # the whole log is kept in build-fuzz/TARGET.log; its head and tail are shown
  (cd build-fuzz && "./tests/fuzz/${target}_fuzzer" "corpus/$target" \
     "${regressions[@]}" "${dictionary[@]}" -max_total_time="$seconds" -max_len=8192 \
     -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 > "$target.log" 2>&1) || {
    # the report starts at a sanitizer's or libFuzzer's ==PID==ERROR line, a UBSan
    # "runtime error:" or a DEADLYSIGNAL line; a looser pattern once matched a harmless
    # ASan WARNING near the top and hid the real report, so show the tail in any case
    grep -m1 -A60 -E "^==[0-9]+== ?ERROR|runtime error:|DEADLYSIGNAL" "build-fuzz/$target.log" || true
    echo "fuzz: $target failed; last lines of build-fuzz/$target.log:"
    tail -40 "build-fuzz/$target.log"
    ls build-fuzz/crash-* build-fuzz/oom-* build-fuzz/timeout-* 2>/dev/null || true
    exit 1
  }
  tail -8 "build-fuzz/$target.log"
done
