#!/bin/bash
# The other-subject set's recipe started where other methods leave it (REPRODUCTION.md, "Started
# at the peers' results or at the truth: what sets the end") and prints its table:
#   experiments/real/anatomy/run_starts.sh
# After `run_other_subject.sh --peers` (it reads the peers' carried templates,
# elastix/elastix_points.off and syn/syn_points.off). For every structure, the scan's experiment
# as `dsnake init --reference ch2` prints it, run as printed; then without its template.init, with template.start = SyN's result,
# elastix's result and the truth phi(p) (NAME_phi.off), and from the truth with the fine phase
# only (phases[0].iterations 0); one thread each.
# Out: out/real/anatomy/other/STRUCTURE/start_{printed,syn,elastix,truth,truth_fine}/. Environment: DSNAKE
# (default build/release/experiments/dsnake), PYTHON (default /usr/bin/python3).
set -euo pipefail
cd "$(dirname "$0")/../../.."
DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
PYTHON=${PYTHON:-/usr/bin/python3}
IN=$(realpath data/real/anatomy/other)
OUT=out/real/anatomy/other
[ -f $IN/inputs.json ] || { echo "run_starts.sh: run experiments/real/anatomy/run_other_subject.sh --peers first" >&2; exit 2; }
STRUCTURES=$("$PYTHON" -c "import json; print(' '.join(json.load(open('$IN/inputs.json'))['structures']))")
for s in $STRUCTURES; do
  for f in "$OUT/$s/syn/syn_points.off" "$OUT/$s/elastix/elastix_points.off"; do
    [ -f "$f" ] || { echo "run_starts.sh: $f is missing: run run_other_subject.sh --peers first" >&2; exit 2; }
  done
  # The recipe as this build's `dsnake init` prints it, run as printed and without its init.
  "$DSNAKE" init --image $IN/${s}_scan.nii.gz --template $IN/${s}_template.off --reference "$(realpath data/real/anatomy/common/ch2.nii.gz)" \
    --mask $IN/${s}_truth.nii.gz >"$OUT/$s/start_printed.json" 2>"$OUT/$s/start_printed.init.log"
  "$PYTHON" -c "import json, sys; e = json.load(open(sys.argv[1])); e['template'].pop('init', None); json.dump(e, open(sys.argv[2], 'w'), indent=1)" \
    "$OUT/$s/start_printed.json" "$OUT/$s/start.json"
  for start in printed syn elastix truth truth_fine; do
    case $start in
      printed)
        "$DSNAKE" run "$OUT/$s/start_printed.json" -o "$OUT/$s/start_printed" -j 1 --quiet --force \
          --set output.start_metrics=true --set ground_truth.correspondence=$IN/${s}_targets.json 2>"$OUT/$s/start_printed.log"
        continue ;;
      syn) file=$OUT/$s/syn/syn_points.off ;;
      elastix) file=$OUT/$s/elastix/elastix_points.off ;;
      *) file=$IN/${s}_phi.off ;;
    esac
    extra=()
    [ $start = truth_fine ] && extra=(--set 'phases[0].iterations=0')
    "$DSNAKE" run "$OUT/$s/start.json" -o "$OUT/$s/start_$start" -j 1 --quiet --force \
      --set output.start_metrics=true --set template.start="$(realpath "$file")" \
      --set ground_truth.correspondence=$IN/${s}_targets.json "${extra[@]}" 2>"$OUT/$s/start_$start.log"
  done
done

"$PYTHON" - "$OUT" $STRUCTURES <<'EOF'
import json, sys
out, names = sys.argv[1], sys.argv[2:]
def cell(path, fit=True):
    try:
        r = json.load(open(path))
    except (OSError, ValueError):
        return "-"
    dice = [r["start"]["metrics"]["dice"]] + ([r["phases"][0]["metrics"]["dice"]] if fit else []) + [r["metrics"]["dice"]]
    return " -> ".join(f"{d:.3f}" for d in dice) + f" ({r['metrics']['correspondence_error_mean']:.2f})"
print("Dice at the start -> after the fit phase -> at the end (correspondence error at the end, mm)")
print()
print("| structure | as printed (image init) | from SyN's result | from elastix's result | from the truth phi(p) | from the truth, fine phase only |")
print("| --- | --- | --- | --- | --- | --- |")
for s in names:
    cells = [s, cell(f"{out}/{s}/start_printed/result.json")]
    cells += [cell(f"{out}/{s}/start_{k}/result.json") for k in ("syn", "elastix", "truth")]
    cells.append(cell(f"{out}/{s}/start_truth_fine/result.json", fit=False))
    print("| " + " | ".join(cells) + " |")
EOF
