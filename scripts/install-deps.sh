#!/usr/bin/env bash
# Installs every build and plotting dependency of Sweep from Debian 12's own archive; with
# --tests what only the test suite uses (a headless browser for the viewer, VTK's reader), with
# --clang what the clang builds use (the fuzzers, ThreadSanitizer): clang and LLVM's OpenMP.
# Idempotent: when everything is already installed it touches nothing (and needs no network).
set -euo pipefail

packages=(
  build-essential cmake clang-format
  libeigen3-dev liburdfdom-dev libfcl-dev libccd-dev libassimp-dev libqhull-dev libsundials-dev libyaml-cpp-dev
  libsuitesparse-dev libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev libpng-dev
  libjs-three pybind11-dev python3-dev python3-matplotlib python3-numpy libopenmpi-dev openmpi-bin
)
for option in "$@"; do
  case "$option" in
    --tests) packages+=(chromium python3-vtk9) ;;
    --clang) packages+=(clang libomp-dev) ;;
    *) echo "install-deps: unknown option $option" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
"${sudo_cmd[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
