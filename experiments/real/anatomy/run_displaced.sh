#!/bin/bash
# The "other subject" scans (make_other_subject.py) placed in other world frames, as a scanner's
# frame differs from the atlas's (REPRODUCTION.md, "A scan in its scanner's frame"), and the
# table of what the recipe makes of them:
#   experiments/real/anatomy/run_displaced.sh
# For every structure, the scan (and its truth) moved by displace_scan.py: not at all; 10 deg and
# 14 mm; 15 deg and 36 mm; 25 deg and 58 mm; and 15 deg and 36 mm keeping 50% of
# the volume's height (another field of view). On each, `dsnake init --image SCAN --template
# TEMPLATE --reference ch2 --mask TRUTH` as printed (template.init.whole_image similarity), and
# the same with template.init.whole_image none (the region's registration from the placement
# alone), one thread. Out: out/real/anatomy/displaced/; data: data/real/anatomy/displaced/.
# Environment: DSNAKE (default build/release/experiments/dsnake), PYTHON (default /usr/bin/python3).
set -euo pipefail
cd "$(dirname "$0")/../../.."
DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
PYTHON=${PYTHON:-/usr/bin/python3}
IN=data/real/anatomy/other
[ -f data/real/anatomy/inputs.json ] || "$PYTHON" experiments/real/anatomy/make_inputs.py "$DSNAKE" .
[ -f $IN/inputs.json ] || "$PYTHON" experiments/real/anatomy/make_other_subject.py "$DSNAKE" .
IN=$(realpath $IN)
ATLAS=$(realpath data/real/anatomy/common/ch2.nii.gz)
DATA=data/real/anatomy/displaced
OUT=out/real/anatomy/displaced
mkdir -p $DATA $OUT
DATA=$(realpath $DATA)
STRUCTURES=$("$PYTHON" -c "import json; print(' '.join(json.load(open('$IN/inputs.json'))['structures']))")
FRAMES=("none 0 0,0,0" "r10 10 10,-8,6" "r15 15 25,-15,20" "r25 25 40,30,-30" "r15crop 15 25,-15,20 2 0.15 0.65")
for s in $STRUCTURES; do
  for f in "${FRAMES[@]}"; do
    set -- $f
    name=$1
    shift
    [ -f $DATA/${name}_${s}_truth.nii.gz ] ||
      "$PYTHON" experiments/real/anatomy/displace_scan.py $DATA/${name}_ "$@" -- $IN/${s}_scan.nii.gz $IN/${s}_truth.nii.gz
    for variant in whole region; do
      run=$OUT/$s/${name}_$variant
      mkdir -p "$(dirname "$run")"
      "$DSNAKE" init --image $DATA/${name}_${s}_scan.nii.gz --template $IN/${s}_template.off --reference $ATLAS \
        --mask $DATA/${name}_${s}_truth.nii.gz >"$run.json" 2>"$run.init.log"
      extra=()
      [ $variant = region ] && extra=(--set template.init.whole_image=none)
      /usr/bin/time -f "%e %M" -o "$run.time" "$DSNAKE" run "$run.json" -o "$run" -j 1 --quiet --force \
        --set output.start_metrics=true "${extra[@]}"
    done
  done
done

"$PYTHON" - "$OUT" $STRUCTURES <<'PY'
import json, sys
out, names = sys.argv[1], sys.argv[2:]
frames = ["none", "r10", "r15", "r25", "r15crop"]
print("Dice at the end (after the image init -> at the end); whole: as printed; region: whole_image none\n")
print("| structure | " + " | ".join(f"{f}: whole / region" for f in frames) + " |")
print("| --- |" + " --- |" * len(frames))
for s in names:
    cells = []
    for f in frames:
        d = []
        for v in ("whole", "region"):
            try:
                r = json.load(open(f"{out}/{s}/{f}_{v}/result.json"))
                d.append(f"{r['metrics']['dice']:.3f}")
            except (OSError, ValueError, KeyError):
                d.append("-")
        cells.append(" / ".join(d))
    print(f"| {s} | " + " | ".join(cells) + " |")
PY
