#!/usr/bin/env bash
# Runs one real experiment of issue 20 (REPRODUCTION.md, "Real scans") with one command:
#   experiments/real/run.sh CASE [DSNAKE]      CASE: lung, cc (2D), liver, femur (3D)
# makes the case's inputs from the package data if they are missing (data/real/CASE/, not
# committed; data/scans/ comes from scripts/fetch_scans.sh), runs experiments/real/CASE/sweep.json
# (the methods recipe, classical, paper, fixed_point) into out/real/CASE/ and prints the table.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
CASE="${1:?usage: experiments/real/run.sh CASE [DSNAKE]}"
B="${2:-$ROOT/build/release/experiments/dsnake}"
PY=/usr/bin/python3  # Debian's, with numpy and scipy (scripts/setup.sh)
[ -f "$ROOT/experiments/real/$CASE/sweep.json" ] || { echo "run.sh: no case '$CASE' (experiments/real/*/sweep.json)" >&2; exit 2; }
case "$CASE" in
  lung|cc) [ -s "$ROOT/data/real/$CASE/template.txt" ] || "$PY" "$ROOT/experiments/real/make_2d_inputs.py" "$B" "$ROOT" ;;
  *) [ -x "$ROOT/experiments/real/$CASE/make_inputs.sh" ] && bash "$ROOT/experiments/real/$CASE/make_inputs.sh" "$B" ;;
esac
"$B" sweep "$ROOT/experiments/real/$CASE/sweep.json" --out "$ROOT/out/real/$CASE" -j 1 -q
"$PY" "$ROOT/experiments/real/table.py" "$ROOT/out/real/$CASE"
