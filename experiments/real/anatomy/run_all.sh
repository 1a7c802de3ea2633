#!/bin/bash
# The anatomy development set, end to end: makes the inputs if missing
# (experiments/real/anatomy/make_inputs.py -> data/real/anatomy/), runs dsnake's methods per case
# (experiments/real/run.sh anatomy/CASE -> out/real/anatomy/CASE/), the peers per case
# (experiments/real/elastix.sh -> out/real/anatomy/CASE/elastix/, experiments/real/syn.py ->
# out/real/anatomy/CASE/syn/; on the warp cases with the template vertices' correspondence), then
# prints the table (experiments/real/anatomy/table.py).
#
#   experiments/real/anatomy/run_all.sh [all | dsnake | elastix | syn | table]   (default all)
#
# Resumable: a finished peer (summary.json) is skipped, and so is a finished dsnake run made by
# this build from the same inputs (a rebuild, even of unrelated code, runs every dsnake run again:
# docs/sweeps.md); delete out/real/anatomy/ after remaking the inputs. Two streams side by side (2 jobs): the dsnake runs
# then SyN, and elastix; each process with THREADS threads (default 1, so that the wall times of
# dsnake, elastix and SyN compare one core each). Logs: out/real/anatomy/{dsnake_syn,elastix}.log.
# Environment: DSNAKE (default build/release/experiments/dsnake), THREADS, CASES (default all nine).
set -euo pipefail
cd "$(dirname "$0")/../../.."
export DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
export THREADS=${THREADS:-1}
WHAT=${1:-all}
CASES=${CASES:-"amygdala_warp pallidum_warp cerebellum_warp amygdala_mirror pallidum_mirror cerebellum_mirror amygdala_cross pallidum_cross cerebellum_cross"}
OUT=out/real/anatomy
mkdir -p "$OUT"
[ -f data/real/anatomy/inputs.json ] || nice /usr/bin/python3 experiments/real/anatomy/make_inputs.py "$DSNAKE" .

dsnake_stream() {
  for c in $CASES; do
    echo "== $c"
    nice bash experiments/real/run.sh "anatomy/$c" || echo "run_all: dsnake on $c failed"
  done
}

peer_args() {  # peer_args CASE: sets d, v (the peers' surface vertices), corr (the warp cases' targets)
  d=data/real/anatomy/$1
  # the surfaces of the peers' masks: 3000 vertices, 2000 for the small structures (the amygdala's
  # mask surface has fewer than 3000 vertices)
  v=2000
  case $1 in cerebellum_*) v=3000 ;; esac
  corr=""
  [ -e "$d/targets.json" ] && corr=$d/targets.json
  return 0
}

elastix_stream() {
  local d v corr
  for c in $CASES; do
    peer_args "$c"
    [ -f "$OUT/$c/elastix/summary.json" ] && continue
    echo "== elastix $c"
    VERTICES=$v CORRESPONDENCE=$corr nice bash experiments/real/elastix.sh "$d/image.nii.gz" "$d/reference.nii.gz" \
      "$d/template.off" "$d/truth.nii.gz" "$OUT/$c/elastix" || echo "run_all: elastix on $c failed"
  done
}

syn_stream() {
  local d v corr
  for c in $CASES; do
    peer_args "$c"
    [ -f "$OUT/$c/syn/summary.json" ] && continue
    echo "== syn $c"
    VERTICES=$v nice /usr/bin/python3 experiments/real/syn.py "$d/image.nii.gz" "$d/reference.nii.gz" \
      "$d/template.off" "$d/truth.nii.gz" "$OUT/$c/syn" ${corr:+--targets "$corr"} || echo "run_all: SyN on $c failed"
  done
}

case $WHAT in
  dsnake) dsnake_stream ;;
  elastix) elastix_stream ;;
  syn) syn_stream ;;
  all)
    { dsnake_stream; syn_stream; } >"$OUT/dsnake_syn.log" 2>&1 &
    a=$!
    elastix_stream >"$OUT/elastix.log" 2>&1 &
    b=$!
    wait $a $b ;;
  table) ;;
  *) echo "usage: run_all.sh [all | dsnake | elastix | syn | table]" >&2; exit 2 ;;
esac
/usr/bin/python3 experiments/real/anatomy/table.py "$OUT"
