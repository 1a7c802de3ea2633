#!/usr/bin/env bash
# Installs what is missing, builds, and runs the built-in default experiment into out/default.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
./build/release/experiments/dsnake run --out out/default "$@"
