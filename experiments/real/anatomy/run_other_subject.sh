#!/bin/bash
# Runs the "other subject" set (make_other_subject.py; REPRODUCTION.md, "Another subject, another
# scanner") and prints its table:
#   experiments/real/anatomy/run_other_subject.sh [--peers]
# For every structure and scan variant (scan: response, bias and noise; scan_t2: the same made
# T2-like; clean: the warped ch2 alone; noise: the warped ch2 plus noise), `dsnake init --image
# SCAN --template TEMPLATE --reference ch2 --mask TRUTH` as printed, then `dsnake run` with
# output.start_metrics and ground_truth.correspondence (the targets phi(p)), one thread, under
# /usr/bin/time; and a 0-iteration run of the template at phi(p) (what the truth scores at 450
# vertices). With --peers also elastix (experiments/real/elastix.sh) and SyN (syn.py) on `scan`,
# 2000-vertex masks, one thread each (7-20 min per structure).
# Out: out/real/anatomy/other/. Environment: DSNAKE (default build/release/experiments/dsnake),
# PYTHON (default /usr/bin/python3).
set -euo pipefail
cd "$(dirname "$0")/../../.."
DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
PYTHON=${PYTHON:-/usr/bin/python3}
IN=data/real/anatomy/other
OUT=out/real/anatomy/other
[ -f data/real/anatomy/inputs.json ] || "$PYTHON" experiments/real/anatomy/make_inputs.py "$DSNAKE" .
[ -f $IN/inputs.json ] || "$PYTHON" experiments/real/anatomy/make_other_subject.py "$DSNAKE" .
IN=$(realpath $IN)  # the experiment files resolve relative paths against their own folder
ATLAS=$(realpath data/real/anatomy/common/ch2.nii.gz)
mkdir -p "$OUT"
STRUCTURES=$("$PYTHON" -c "import json; print(' '.join(json.load(open('$IN/inputs.json'))['structures']))")
for s in $STRUCTURES; do
  for v in scan scan_t2 clean noise; do
    image=$IN/${s}_$v.nii.gz
    run=$OUT/$s/$v
    mkdir -p "$run"
    "$DSNAKE" init --image "$image" --template $IN/${s}_template.off --reference $ATLAS --mask $IN/${s}_truth.nii.gz \
      >"$run.json" 2>"$run.init.log"
    /usr/bin/time -f "%e %M" -o "$run.time" "$DSNAKE" run "$run.json" -o "$run" -j 1 --quiet --force \
      --set output.start_metrics=true --set ground_truth.correspondence=$IN/${s}_targets.json
  done
  cat >"$OUT/$s/phi.json" <<EOF
{"dimension": 3, "name": "phi", "image": {"file": "$IN/${s}_scan.nii.gz"},
 "template": {"file": "$IN/${s}_phi.off"}, "ground_truth": {"mask": "$IN/${s}_truth.nii.gz"},
 "field": {"type": "gradient"}, "energies": [{"type": "internal", "weight": 1.0}], "phases": [{"iterations": 0}],
 "output": {"figures": false}}
EOF
  "$DSNAKE" run "$OUT/$s/phi.json" -o "$OUT/$s/phi" -j 1 --quiet --force
  if [ "${1:-}" = --peers ]; then
    VERTICES=2000 THREADS=1 CORRESPONDENCE=$IN/${s}_targets.json bash experiments/real/elastix.sh $IN/${s}_scan.nii.gz \
      $ATLAS $IN/${s}_template.off $IN/${s}_truth.nii.gz "$OUT/$s/elastix" >"$OUT/$s/elastix.log" 2>&1
    VERTICES=2000 OMP_NUM_THREADS=1 "$PYTHON" experiments/real/syn.py $IN/${s}_scan.nii.gz $ATLAS \
      $IN/${s}_template.off $IN/${s}_truth.nii.gz "$OUT/$s/syn" --targets $IN/${s}_targets.json >"$OUT/$s/syn.log" 2>&1
  fi
done

"$PYTHON" - "$OUT" $STRUCTURES <<'EOF'
import json, os, sys
out, names = sys.argv[1], sys.argv[2:]
def res(path):
    try:
        return json.load(open(path))
    except (OSError, ValueError):
        return None
def peer(s, name):  # the peers' summary.json: their mask's metrics, the template's vertices carried
    r = res(f"{out}/{s}/{name}/summary.json")
    if not r:
        return "-"
    m, t = r["metrics"], r.get("carried_template_metrics") or {}
    wall = r.get("elastix_wall_s", r.get("syn_wall_s"))
    return (f"{m['dice']:.3f} / {m['mean_surface_distance']:.2f} / {r.get('correspondence_error_mean') or 0:.2f}"
            f" (carried {t.get('dice', 0):.3f}; {wall:.0f} s)")
print("Dice / mean surface distance (mm) / mean correspondence error (mm); dsnake: Dice after the image init -> at the end; peers: their 2000-vertex masks (the template's vertices carried by their transforms; wall time)")
print()
print("| structure | truth at phi(p) | dsnake, scan | dsnake, T2-like scan | dsnake, clean | dsnake, noise only | elastix | SyN | dsnake s, MB |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for s in names:
    phi = res(f"{out}/{s}/phi/result.json")
    cells = [s, f"{phi['metrics']['dice']:.3f}" if phi else "-"]
    for v in ("scan", "scan_t2", "clean", "noise"):
        r = res(f"{out}/{s}/{v}/result.json")
        if not r:
            cells.append("-")
            continue
        m, st = r["metrics"], r["start"]["metrics"]
        cells.append(f"{st['dice']:.3f} -> {m['dice']:.3f} / {m['mean_surface_distance']:.2f} / "
                     f"{m['correspondence_error_mean']:.2f}")
    cells += [peer(s, "elastix"), peer(s, "syn")]
    t = open(f"{out}/{s}/scan.time").read().split() if os.path.exists(f"{out}/{s}/scan.time") else None
    cells.append(f"{float(t[0]):.1f}, {int(t[1]) // 1024}" if t else "-")
    print("| " + " | ".join(cells) + " |")
EOF
