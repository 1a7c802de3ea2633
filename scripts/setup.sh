#!/usr/bin/env bash
# Installs the Debian 12 packages dsnake needs (as root; skipped when all are present) and
# configures + builds a preset with ninja: `release` (the default), or `sanitize` (clang with
# AddressSanitizer, UndefinedBehaviorSanitizer and the libFuzzer targets; adds clang's packages).
set -euo pipefail
cd "$(dirname "$0")/.."
PRESET=${1:-release}
PACKAGES=(cmake ninja-build ccache g++ libeigen3-dev libceres-dev libopenmesh-dev libopencv-dev
          nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev libspdlog-dev
          zlib1g-dev libpng-dev libfftw3-dev libgdcm-dev libssl-dev libboost-dev parallel python3-matplotlib python3-jsonschema python3-vtk9
          python3-numpy python3-scipy python3-nibabel python3-dipy elastix
          pybind11-dev python3-dev python3-pytest python3-nbconvert python3-nbformat python3-ipykernel
          jupyter-nbconvert mypy slurmctld slurmd slurm-client munge)
[ "$PRESET" = sanitize ] && PACKAGES+=(clang-14 libclang-rt-14-dev libomp-14-dev)
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
# The Stanford bunny for experiments/paper/bunny_*.json (npm registry; not committed; no test
# needs it, so a failed download only warns).
scripts/fetch_bunny.sh || echo "setup: warning: the bunny was not fetched; only experiments/paper/bunny_*.json need it" >&2
# Real scans for the reader, template and real-scan tests (Debian archive and npm; not
# committed; sources and licences in the script). The tests need them, so a failure stops here.
scripts/fetch_scans.sh
cmake --preset "$PRESET" >/dev/null
# CMake starts a build folder's cache afresh when its compiler changes (a build/sanitize first
# configured with g++, then with the preset's clang) and then drops the preset's other variables:
# that build would have no sanitizers, silently. A second configure applies them.
want_type=Release
[ "$PRESET" = sanitize ] && want_type=Debug
if ! grep -qx "CMAKE_BUILD_TYPE:STRING=$want_type" "build/$PRESET/CMakeCache.txt"; then
  cmake --preset "$PRESET" >/dev/null
  grep -qx "CMAKE_BUILD_TYPE:STRING=$want_type" "build/$PRESET/CMakeCache.txt" ||
    { echo "setup: build/$PRESET is not configured as the $PRESET preset says; remove that folder and run again" >&2; exit 1; }
fi
cmake --build --preset "$PRESET"
# `import dsnake` for the system python3 from any folder (docs/python.md): a .pth file in its
# site-packages names this build's module folder (the checkout set up last is the one imported).
if [ "$PRESET" = release ]; then
  pth="$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])')/dsnake.pth"
  module_dir="$PWD/build/release/python"
  if [ "$(cat "$pth" 2>/dev/null)" != "$module_dir" ]; then
    $SUDO mkdir -p "$(dirname "$pth")"
    echo "$module_dir" | $SUDO tee "$pth" >/dev/null
  fi
fi
