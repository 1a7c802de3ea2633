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
          jupyter-nbconvert mypy slurmctld slurmd slurm-client munge chromium)
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
# npm (the scans, the bunny and the report viewer's packages): Debian's, unless a node.js with its
# own npm is installed already (a NodeSource nodejs conflicts with Debian's npm package).
if ! command -v npm >/dev/null; then
  echo "setup: installing npm" >&2
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends npm
fi
# The Stanford bunny for experiments/paper/bunny_*.json (npm registry; not committed; no test
# needs it, so a failed download only warns).
scripts/fetch_bunny.sh || echo "setup: warning: the bunny was not fetched; only experiments/paper/bunny_*.json need it" >&2
# Real scans for the reader, template and real-scan tests (Debian archive and npm; not
# committed; sources and licences in the script). The tests need them, so a failure stops here.
scripts/fetch_scans.sh
# The report viewer's npm packages (three.js, esbuild), exactly as viewer/package-lock.json pins
# them, for the CMake target dsnake_viewer (docs/reports.md); skipped while node_modules holds
# that lock file's packages, so a rerun needs no network.
lock_sum=$(sha256sum viewer/package-lock.json | cut -d' ' -f1)
if [ "$(cat viewer/node_modules/.dsnake-lock-sha256 2>/dev/null)" != "$lock_sum" ]; then
  command -v npm >/dev/null || { echo "setup: npm is needed for viewer/ (the report's 3D view)" >&2; exit 1; }
  npm ci --prefix viewer --no-audit --no-fund --prefer-offline
  echo "$lock_sum" > viewer/node_modules/.dsnake-lock-sha256
fi
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
