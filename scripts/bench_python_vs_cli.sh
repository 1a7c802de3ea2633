#!/bin/bash
# Whole-process timing of one experiment run by the dsnake executable and by dsnake.run() in the
# system python3, interleaved (each round runs both), with /usr/bin/time -v's wall time, peak
# resident memory and minor page faults; prints the minimum and median of each.
# Usage: scripts/bench_python_vs_cli.sh [EXPERIMENT] [ROUNDS]   (default: the lung phantom, 5 rounds)
set -euo pipefail
cd "$(dirname "$0")/.."
config=${1:-experiments/paper/lung_dsnake.json}
rounds=${2:-5}
dsnake=build/release/experiments/dsnake
export PYTHONPATH=$PWD/build/release/python
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for r in $(seq "$rounds"); do
  /usr/bin/time -v "$dsnake" run "$config" --out "$work/cli" >/dev/null 2>"$work/time"
  awk -v w=cli '/Elapsed/{split($NF,t,":"); s=t[1]*60+t[2]} /Maximum resident/{m=$NF} /Minor/{f=$NF} END{print w, s, m, f}' "$work/time"
  /usr/bin/time -v /usr/bin/python3 -c "import dsnake, sys; dsnake.run(sys.argv[1])" "$config" >/dev/null 2>"$work/time"
  awk -v w=python '/Elapsed/{split($NF,t,":"); s=t[1]*60+t[2]} /Maximum resident/{m=$NF} /Minor/{f=$NF} END{print w, s, m, f}' "$work/time"
done | /usr/bin/python3 -c '
import sys, collections, statistics
d = collections.defaultdict(list)
for line in sys.stdin:
    w, s, m, f = line.split()
    d[w].append((float(s), int(m), int(f)))
for w, v in d.items():
    s = [x[0] for x in v]
    print(f"{w:7s} wall min {min(s):6.2f} s  median {statistics.median(s):6.2f} s  peak {max(x[1] for x in v) / 1024:6.0f} MB"
          f"  minor faults median {statistics.median(x[2] for x in v):8.0f}  n={len(v)}")
'
