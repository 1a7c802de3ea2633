#!/bin/bash
# Interleaved A/B timing of Google Benchmark programs on a noisy host: every round runs each
# program once (4 repetitions, 0.3 s each), and the minimum and median of all timings per
# benchmark and program are printed.
# Usage: scripts/bench_ab.sh FILTER ROUNDS PROGRAM...
#   e.g. scripts/bench_ab.sh 'BM_Pass/vertices:7000/threads:1' 3 /tmp/bench_remesh_before \
#          build/release/experiments/bench/bench_remesh
set -euo pipefail
filter=$1; rounds=$2; shift 2
for r in $(seq "$rounds"); do
  for b in "$@"; do
    "$b" --benchmark_filter="$filter" --benchmark_repetitions=4 --benchmark_min_time=0.3 --benchmark_format=csv 2>/dev/null |
      grep '^"BM' | grep -v '_mean\|_median\|_stddev\|_cv' | awk -F, -v b="$b" '{print b, $1, $3}'
  done
done | python3 -c '
import sys, collections, statistics
d = collections.defaultdict(list)
for line in sys.stdin:
    b, n, t = line.split()
    d[(n, b)].append(float(t))
for (n, b), v in sorted(d.items()):
    print(f"{n:55s} {b:40s} min {min(v):8.2f} med {statistics.median(v):8.2f} n={len(v)}")
'
