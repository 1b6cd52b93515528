#!/usr/bin/env bash
# Fuzzes the scene parser, the URDF importer, saved states and the viewer's snapshot reader
# with libFuzzer (clang), under AddressSanitizer
# and UndefinedBehaviorSanitizer. Usage:
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET ...]  (default: 60 s, scene, settings, snapshot, state, urdf)
# The seed corpus is every scene and URDF of examples/ and tests/data/, the saved states and
# snapshots of tests/fuzz/seeds/, plus the inputs that once crashed Sweep (tests/fuzz/regressions/,
# replayed first). The YAML targets mutate with tests/fuzz/scene.dict (the parser's keys). The
# targets are built in the sanitizer suite's tree (scripts/asan-tree.sh) and run one per core.
# A crash leaves its input in build-asan/fuzz/TARGET-crash-* and makes this script fail; add the
# input to tests/fuzz/regressions/TARGET/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scene settings snapshot state urdf)

./scripts/asan-tree.sh "${targets[@]/%/_fuzzer}"
work=build-asan/fuzz
mkdir -p "$work"

# Runs one target; its whole log is kept in build-asan/fuzz/TARGET.log
fuzz_one() {
  local target="$1"
  local corpus="$work/corpus/$target"
  mkdir -p "$corpus"
  case "$target" in
    # a scene file is a settings file too: its top-level keys are paths
    scene | settings) find examples tests/data/scenes -name '*.yaml' -exec cp {} "$corpus/" \; ;;
    urdf) find examples tests/data -name '*.urdf' -exec cp {} "$corpus/" \; ;;
    state | snapshot) cp "tests/fuzz/seeds/$target"/* "$corpus/" ;;
  esac
  local options=()
  case "$target" in scene | settings) options=(-dict=tests/fuzz/scene.dict) ;; esac
  # the regressions replay first: libFuzzer runs every given corpus before mutating (a target
  # that never broke has no folder, and libFuzzer refuses a folder that does not exist)
  [ -d "tests/fuzz/regressions/$target" ] && options+=("tests/fuzz/regressions/$target")
  echo "fuzz: $target for $seconds s"
  "build-asan/tests/fuzz/${target}_fuzzer" "$corpus" "${options[@]}" \
    -artifact_prefix="$work/$target-" -max_total_time="$seconds" -max_len=8192 -timeout=20 \
    -rss_limit_mb=2048 -print_final_stats=1 > "$work/$target.log" 2>&1
}

# Shows why a target failed
report() {
  local target="$1"
  # the report starts at a sanitizer's or libFuzzer's ==PID==ERROR line, a UBSan
  # "runtime error:" or a DEADLYSIGNAL line; a looser pattern once matched a harmless
  # ASan WARNING near the top and hid the real report, so show the tail in any case
  grep -m1 -A60 -E "^==[0-9]+== ?ERROR|runtime error:|DEADLYSIGNAL" "$work/$target.log" || true
  echo "fuzz: $target failed; last lines of $work/$target.log:"
  tail -40 "$work/$target.log"
  ls "$work/$target"-* 2>/dev/null || true
}

# one target per core: a libFuzzer process runs on one thread
declare -A pids
failed=()
running=0
for target in "${targets[@]}"; do
  if [ "$running" -ge "$(nproc)" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  fuzz_one "$target" &
  pids[$target]=$!
  running=$((running + 1))
done
for target in "${targets[@]}"; do
  if wait "${pids[$target]}"; then
    tail -8 "$work/$target.log"
  else
    report "$target"
    failed+=("$target")
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: failed: ${failed[*]}"
  exit 1
fi
