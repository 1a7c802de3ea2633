#!/bin/bash
# Runs one real-scan experiment (REPRODUCTION.md, Real scans) and prints its table:
#   experiments/real/run.sh CASE        (CASE: a folder experiments/real/CASE/ holding sweep.json;
#                                        anatomy/NAME: the anatomy development set's cases, inputs
#                                        from experiments/real/anatomy/make_inputs.py)
# Makes the inputs (data/real/CASE/, not committed) if they are missing, runs the sweep's runs one
# at a time into out/real/CASE/ (resumable: a finished run made by this build from the same
# inputs is skipped), and prints per method:
# Dice, mean surface distance, HD95 (mm), self-intersections, Euler characteristic, wall time and
# peak memory of the run (/usr/bin/time), and for the fixed_point methods the centroid's shift.
# Environment: DSNAKE (default build/release/experiments/dsnake), THREADS (OpenMP threads per run,
# default 2), PYTHON (default /usr/bin/python3: Debian's, with numpy and scipy).
#
# The runs are those of `dsnake sweep experiments/real/CASE/sweep.json --out out/real/CASE -j 1`,
# executed from its --manifest under /usr/bin/time so that each run's peak memory is known, then
# aggregated with --aggregate-only (out/real/CASE/results.csv).
#
# A run's id hashes its experiment, not its input files: after remaking the inputs, delete
# out/real/CASE/ (the inputs script is only run when data/real/CASE/ lacks them).
set -euo pipefail
cd "$(dirname "$0")/../.."
CASE=${1:?usage: experiments/real/run.sh CASE}
DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
THREADS=${THREADS:-2}
PYTHON=${PYTHON:-/usr/bin/python3}
SWEEP=experiments/real/$CASE/sweep.json
OUT=out/real/$CASE
[ -f "$SWEEP" ] || { echo "run.sh: no $SWEEP" >&2; exit 2; }

case $CASE in
  liver | femur) [ -f data/real/$CASE/inputs.json ] || "$PYTHON" experiments/real/make_3d_inputs.py "$DSNAKE" . "$CASE" ;;
  anatomy/*) [ -f data/real/anatomy/inputs.json ] || "$PYTHON" experiments/real/anatomy/make_inputs.py "$DSNAKE" . ;;
  *) [ -d data/real/$CASE ] || "$PYTHON" experiments/real/make_2d_inputs.py "$DSNAKE" . ;;
esac

mkdir -p "$OUT/configs" "$OUT/time" "$OUT/logs"

"$DSNAKE" sweep "$SWEEP" --out "$OUT" --manifest parallel >/dev/null
while read -r line; do
  [ -n "$line" ] || continue
  id=$(sed -E 's|.* --out ([^ ]*/)?runs/([^ ]+).*|\2|' <<<"$line")
  echo "run.sh: $id" >&2
  cmd=${line/--threads 1/--threads $THREADS}
  cmd=${cmd/ --quiet/}
  # the manifest's paths are relative to the sweep folder, its executable "${DSNAKE:-...}"
  if ! /usr/bin/time -f "%e %M" -o "$OUT/time/$id.txt" env DSNAKE="$DSNAKE" bash -c "cd \"$OUT\" && $cmd" 2>"$OUT/logs/$id.log"; then
    echo "run.sh: $id failed: $(tail -1 "$OUT/logs/$id.log")" >&2
  fi
done <"$OUT/manifest.txt"
"$DSNAKE" sweep "$SWEEP" --out "$OUT" --aggregate-only >/dev/null

"$PYTHON" - "$OUT" <<'EOF'
import json, os, sys

out = sys.argv[1]


import csv

rows = []
for run in csv.DictReader(open(f"{out}/results.csv")):  # the sweep's current runs (not stale ones in runs/)
    rid, method = run["run_id"], run["method"]
    d = f"{out}/runs/{rid}"
    if not os.path.exists(f"{d}/result.json"):
        print(f"{method:<18} missing")
        continue
    r = json.load(open(f"{d}/result.json"))
    m = r["metrics"]
    t = open(f"{out}/time/{rid}.txt").read().split() if os.path.exists(f"{out}/time/{rid}.txt") else ["nan", "0"]
    # The result's Euler characteristic (3D runs that remeshed) and centroid shift, from result.json.
    chi = r.get("mesh_quality", {}).get("euler_characteristic", "-")
    shift = f"{r['pose']['centroid_shift']:.2f}" if "pose" in r else "-"
    start = r.get("start", {}).get("metrics", {})
    if start:
        print(f"{method:<18} started at Dice {start['dice']:.4f}, msd {start['mean_surface_distance']:.3f} mm")
    rows.append((method, m.get("dice"), m.get("mean_surface_distance"), m.get("hausdorff95"), m.get("self_intersections"),
                 chi, r["vertices"]["final"], r.get("iterations"), float(t[0]), int(t[1]) / 1024.0,
                 r["timings"].get("metrics_s", 0.0), shift))
order = ["classical", "paper", "recipe", "recipe_noref", "fixed_point"]
rows.sort(key=lambda x: (order.index(x[0]) if x[0] in order else len(order), x[0]))
fmt = lambda x, p: "-" if x is None else (f"{x:.{p}f}" if isinstance(x, float) else str(x))
print(f"{'method':<18} {'Dice':>6} {'msd mm':>7} {'HD95 mm':>8} {'SI':>4} {'chi':>4} {'verts':>6} {'iters':>6} "
      f"{'wall s':>7} {'peak MB':>8} {'metrics s':>9} {'centroid shift mm':>17}")
for x in rows:
    print(f"{x[0]:<18} {fmt(x[1], 4):>6} {fmt(x[2], 3):>7} {fmt(x[3], 3):>8} {fmt(x[4], 0):>4} {x[5]:>4} {x[6]:>6} "
          f"{fmt(x[7], 0):>6} {x[8]:>7.1f} {x[9]:>8.0f} {x[10]:>9.1f} {x[11]:>17}")
EOF
