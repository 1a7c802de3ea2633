#!/usr/bin/env bash
# Fuzzes every libFuzzer target of tests/fuzz for SECONDS each (default 600), JOBS
# targets at a time (default 2), from a working copy of the committed seed corpus, and prints one
# line per target: executions, executions per second, coverage (libFuzzer's "cov" edges and "ft"
# features), corpus size and findings. Needs the sanitize preset's build:
#   cmake --preset sanitize && cmake --build --preset sanitize
#   SECONDS_PER_TARGET=600 bash scripts/fuzz.sh [target ...]
# Findings (crash-*, leak-*, oom-*, timeout-*) are kept in $WORK/<target>/findings; copy each into
# tests/fuzz/corpus/<target>/crash_<name> once fixed, so that CI replays it.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET=${SECONDS_PER_TARGET:-600}
JOBS=${JOBS:-2}
WORK=${WORK:-/tmp/dsnake-fuzz}
BIN=build/sanitize/tests/fuzz
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(experiment_file sweep_file set_path metaimage nifti nrrd inr raster contour mesh)
for t in "${TARGETS[@]}"; do
  [ -x "$BIN/fuzz_$t" ] || { echo "fuzz.sh: $BIN/fuzz_$t is missing: build the sanitize preset first" >&2; exit 2; }
done

run_one() {
  local t=$1 dir=$WORK/$1
  rm -rf "$dir"; mkdir -p "$dir/corpus" "$dir/findings"
  cp tests/fuzz/corpus/"$t"/* "$dir/corpus/"
  local start=$SECONDS
  # -rss_limit_mb: an input that makes a reader allocate past 2 GB is a finding (no
  # allocation without bound); -timeout: one input taking over 20 s is a finding (a hang).
  ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$BIN/fuzz_$t" "$dir/corpus" -max_total_time="$SECONDS_PER_TARGET" -rss_limit_mb=2048 -timeout=20 \
      -artifact_prefix="$dir/findings/" -print_final_stats=1 -close_fd_mask=3 >"$dir/log" 2>&1 || true
  local elapsed=$((SECONDS - start)) execs rate cov ft corp found
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$dir/log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$dir/log" | grep -o '[0-9]*$' | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$dir/log" | tail -1 | grep -o '[0-9]*')
  ft=$(grep -o 'ft: [0-9]*' "$dir/log" | tail -1 | grep -o '[0-9]*')
  corp=$(ls "$dir/corpus" | wc -l)
  found=$(ls "$dir/findings" | wc -l)
  # A finding stops libFuzzer: the time then says how long the target ran before it.
  printf '%-16s %5s s %10s execs %6s/s  cov %6s  ft %6s  corpus %5s  findings %s\n' "$t" "$elapsed" "${execs:-?}" \
    "${rate:-?}" "${cov:-?}" "${ft:-?}" "$corp" "$found"
}
export -f run_one
export WORK BIN SECONDS_PER_TARGET
printf '%s\n' "${TARGETS[@]}" | xargs -P "$JOBS" -I{} bash -c 'run_one {}'
