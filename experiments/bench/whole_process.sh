#!/bin/bash
# Whole-process figures: each case runs REPEATS times (default 5) under /usr/bin/time -v
# and prints the median wall time (s) and the median peak resident memory (MB), with the
# figure the in-process benchmark or result.json gives for the same work beside it.
#
# Cases (all by default; name some to run only those):
#   field         dsnake field, converged multigrid GVF on the 230 x 300 x 80 ellipsoid of the
#                 in-process benchmark (BM_GvfMultigridConverged3d), 1 thread
#   lung_j1       experiments/paper/lung_dsnake.json end to end, 1 thread
#   lung_j1_warm  the same, each run right after first_touch (below) has touched and freed 450 MB:
#                 the memory the run maps is still backed by the host (not in the default list)
#   lung_j2       the same, 2 threads
#   lung_busy_j1  the same, 1 thread, while another process keeps one core busy
#   lung_busy_j2  the same, 2 threads, while another process keeps one core busy
#   ct            experiments/bench/ct_lung.json: a 512 x 512 x 300 lung phantom, a 506-vertex
#                 template refined to about 7000 vertices, 2 threads
#   ct_read       dsnake convert of a CT-sized scan as converters write it (512 x 512 x 300 int16
#                 .nii.gz with scl_slope and scl_inter, experiments/bench/make_volumes.py --ct) to
#                 .mha: reading, decoding and writing a real scan's volume, 1 thread
#   ct_read_nrrd  the same CT as gzip-encoded float32 .nrrd (made once from ct_scan.nii.gz with
#                 `dsnake convert --compress`, as 3D Slicer saves), converted to .mha, 1 thread
#   ct_read_mha   the same CT as raw float32 .mha (made once likewise), converted to .nii, 1 thread
#   liver_metrics the liver case's recipe (experiments/real/liver) with 0 iterations: the metrics
#                 of its 300-vertex template on the 25.5 M-voxel truth (needs data/real/liver,
#                 from experiments/real/make_3d_inputs.py); result.json's metrics_s beside
#   collapsed_metrics  the same template shrunk 100 times about its centroid
#   first_touch   not dsnake: the machine's cost, at that moment, of touching 320 MB of fresh
#                 memory (the lung run's peak), REPEATS times 3 s apart (freed memory goes back
#                 to the host after about 2 s), and of touching it again right after
#                 (experiments/bench/first_touch.cpp). It moves the lung's figures by tenths of
#                 a second from one hour to the next; run first and last by default.
#   field_types   dsnake field of every field type (gradient, distance, gvf, ddgvf, vfc) on the
#                 same volume, 1 thread: peak bytes per voxel of each (not in the default list)
#
# Every run starts GAP seconds (default 3) after the one before: on a virtual machine that hands
# freed memory back to its host (free page reporting, after about 2 s), a run that starts right
# after another finds the other's pages still backed and runs faster than a user's single run
# (the lung with -j 1: 0.7-0.9 s faster, its system time 0.73-0.97 -> 0.11-0.29 s; GAP=0 gives
# those figures).
#
# Usage: experiments/bench/whole_process.sh [CASE ...]    (env: REPEATS, DSNAKE, WORK, GAP)
set -euo pipefail
cd "$(dirname "$0")/../.."
DSNAKE=${DSNAKE:-build/release/experiments/dsnake}
REPEATS=${REPEATS:-5}
GAP=${GAP:-3}
WORK=${WORK:-/tmp/dsnake-whole-process}
mkdir -p "$WORK"
[ -f "$WORK/ellipsoid.mha" ] && [ -f "$WORK/ct_scan.nii.gz" ] || /usr/bin/python3 experiments/bench/make_volumes.py "$WORK" --ct

HOG=""
start_hog() { (while :; do :; done) & HOG=$!; }
# (wait returns the killed hog's status 143: it must not end the script under set -e)
stop_hog() { if [ -n "$HOG" ]; then kill "$HOG" 2>/dev/null || true; wait "$HOG" 2>/dev/null || true; fi; HOG=""; return 0; }
trap stop_hog EXIT

# measure NAME INPROCESS_NOTE COMMAND...: REPEATS runs, medians of wall time and peak RSS.
measure() {
  local name=$1 note=$2
  shift 2
  local times=()
  for i in $(seq "$REPEATS"); do
    rm -rf "$WORK/out" && mkdir -p "$WORK/out"
    sleep "$GAP"  # the run before's freed memory goes back to the host: every run starts cold
    if [ -n "${BEFORE_EACH:-}" ]; then $BEFORE_EACH > /dev/null; fi
    if ! /usr/bin/time -v -o "$WORK/time.txt" "$@" > "$WORK/stdout.txt" 2> "$WORK/stderr.txt"; then
      echo "whole_process: $name failed:" >&2
      tail -5 "$WORK/stderr.txt" >&2
      exit 1
    fi
    times+=("$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; w = s}
                             /Maximum resident set size/ {m = $2} END {print w, m}' "$WORK/time.txt")")
  done
  printf '%s\n' "${times[@]}" | /usr/bin/python3 -c '
import statistics, sys
rows = [tuple(map(float, l.split())) for l in sys.stdin if l.strip()]
name, note = sys.argv[1], sys.argv[2]
wall = statistics.median(r[0] for r in rows)
rss = statistics.median(r[1] for r in rows) / 1024
print(f"{name:18s} wall {wall:7.2f} s (min {min(r[0] for r in rows):6.2f})  peak {rss:7.0f} MB  n={len(rows)}  {note}")
' "$name" "$note"
  LAST_RSS_KB=$(printf '%s\n' "${times[@]}" | awk '{print $2}' | sort -n | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}')
}

# The in-process time of a result.json entry of the last run (timings.KEY, seconds).
timing() { /usr/bin/python3 -c 'import json,sys; print("%.2f" % json.load(open(sys.argv[1]))["timings"][sys.argv[2]])' "$WORK/out/result.json" "$1"; }

run_case() {
  case $1 in
    field)
      # The in-process benchmark of the same work as `dsnake field --type gvf`: the edge map and
      # the converged multigrid solve (BM_GvfField3d), median of 3, 1 thread.
      local bench
      bench=$(build/release/experiments/bench/bench_fields --benchmark_filter='BM_GvfField3d/1/real_time$' \
                --benchmark_repetitions=3 --benchmark_report_aggregates_only=true --benchmark_format=csv 2>/dev/null |
              awk -F, '/_median/ {printf "%.2f", $3 / 1000}')
      measure field "in-process ${bench} s (BM_GvfField3d, 1 thread, median of 3); $(( 230 * 300 * 80 )) voxels" \
        "$DSNAKE" field --image "$WORK/ellipsoid.mha" --type gvf --out "$WORK/gvf.mha" -j 1
      echo "                   peak bytes per voxel: $(awk -v kb="$LAST_RSS_KB" 'BEGIN {printf "%.1f", kb * 1024 / (230 * 300 * 80)}')" ;;
    lung_j1) measure lung_j1 "" "$DSNAKE" run experiments/paper/lung_dsnake.json --out "$WORK/out" -j 1 --quiet ;;
    lung_j1_warm)
      # Right after first_touch has touched and freed 450 MB (not timed): the run's memory is
      # still backed by the host, as it would be on a machine that does not hand freed memory
      # back; the difference to lung_j1 is what this machine charges for the run's fresh pages.
      BEFORE_EACH="build/release/experiments/bench/first_touch 450" measure lung_j1_warm "memory still backed" \
        "$DSNAKE" run experiments/paper/lung_dsnake.json --out "$WORK/out" -j 1 --quiet ;;
    lung_j2) measure lung_j2 "" "$DSNAKE" run experiments/paper/lung_dsnake.json --out "$WORK/out" -j 2 --quiet ;;
    lung_busy_j1)
      start_hog; measure lung_busy_j1 "one core busy" "$DSNAKE" run experiments/paper/lung_dsnake.json --out "$WORK/out" -j 1 --quiet; stop_hog ;;
    lung_busy_j2)
      start_hog; measure lung_busy_j2 "one core busy" "$DSNAKE" run experiments/paper/lung_dsnake.json --out "$WORK/out" -j 2 --quiet; stop_hog ;;
    ct) measure ct "" "$DSNAKE" run experiments/bench/ct_lung.json --out "$WORK/out" -j 2 --quiet
        echo "                   last run: $(/usr/bin/python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print("vertices", r["vertices"], "timings", {k: round(v, 2) for k, v in r["timings"].items()})' "$WORK/out/result.json")" ;;
    ct_read)
      measure ct_read "$(( 512 * 512 * 300 )) voxels, int16 -> float32" "$DSNAKE" convert "$WORK/ct_scan.nii.gz" "$WORK/out/ct_scan.mha" ;;
    ct_read_nrrd|ct_read_mha)
      local from=$WORK/ct_scan.nrrd to=$WORK/out/ct_scan.mha flag=--compress
      [ "$1" = ct_read_mha ] && from=$WORK/ct_scan_raw.mha to=$WORK/out/ct_scan.nii flag=
      [ -f "$from" ] || "$DSNAKE" convert "$WORK/ct_scan.nii.gz" "$from" $flag
      measure "$1" "$(( 512 * 512 * 300 )) voxels, float32" "$DSNAKE" convert "$from" "$to" ;;
    liver_metrics|collapsed_metrics)
      if [ ! -f data/real/liver/truth.mha ]; then echo "$1: skipped: data/real/liver missing (experiments/real/make_3d_inputs.py)"; return; fi
      local scale=1
      [ "$1" = collapsed_metrics ] && scale=0.01
      measure "$1" "" "$DSNAKE" run experiments/real/recipe_3d.json --out "$WORK/out" --quiet \
        --set image.file=$PWD/data/real/liver/image.mha --set template.file=$PWD/data/real/liver/template.off \
        --set ground_truth.mask=$PWD/data/real/liver/truth.mha --set phases[0].iterations=0 --set phases[1].iterations=0 \
        --set template.transform.scale=$scale --set output.figures=false --set output.result_mask=false \
        --field-cache "$WORK/cache"
      echo "                   last run: metrics $(timing metrics_s) s in-process" ;;
    first_touch)
      local probe=build/release/experiments/bench/first_touch
      for i in $(seq "$REPEATS"); do sleep 3; "$probe" 320; done | /usr/bin/python3 -c '
import re, statistics, sys
rows = [tuple(map(float, re.findall(r"\(([\d.]+) s/GB\)", l))) for l in sys.stdin if "first touch" in l]
fresh = [r[0] for r in rows]; again = [r[1] for r in rows]
print(f"first_touch        fresh memory {statistics.median(fresh):.2f} s/GB (min {min(fresh):.2f}, max {max(fresh):.2f}), "
      f"again right after {statistics.median(again):.2f} s/GB  n={len(rows)}  (the machine, not dsnake: 320 MB)")' ;;
    field_types)
      for t in gradient distance gvf ddgvf vfc; do
        measure "field_$t" "" "$DSNAKE" field --image "$WORK/ellipsoid.mha" --type "$t" --out "$WORK/$t.mha" -j 1
        echo "                   peak bytes per voxel: $(awk -v kb="$LAST_RSS_KB" 'BEGIN {printf "%.1f", kb * 1024 / (230 * 300 * 80)}')"
      done ;;
    *) echo "whole_process: unknown case $1" >&2; exit 2 ;;
  esac
}

CASES=("$@")
[ ${#CASES[@]} -gt 0 ] || CASES=(first_touch field lung_j1 lung_j2 lung_busy_j1 lung_busy_j2 ct ct_read liver_metrics collapsed_metrics first_touch)
echo "whole_process: $(nproc) cores, REPEATS=$REPEATS, GAP=$GAP s, $($DSNAKE --version 2>/dev/null | head -1)"
for c in "${CASES[@]}"; do run_case "$c"; done
