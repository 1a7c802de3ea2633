#!/bin/bash
# Thirteen AAL structures outside the development set, none held out, as mirror cases
# (experiments/real/anatomy/make_mirror_case.py -> data/real/anatomy/more/NAME/), registered with
# `dsnake init` as printed, with and without --reference (one thread, into
# out/real/anatomy/more/NAME/{recipe,noref}/), beside elastix and SyN (experiments/real/elastix.sh,
# syn.py: 2000-vertex mask surfaces, one thread), then the table of REPRODUCTION.md's "The fit
# phase's patch weight; thirteen more structures beside the peers".
#
#   experiments/real/anatomy/run_more.sh [all | dsnake | peers | table]   (default all)
#
# Resumable: a case, a run or a peer whose output exists is skipped (delete its folder to redo
# it). Two streams side by side with `all`: the dsnake runs then SyN, and elastix. Needs
# make_inputs.py's data/real/anatomy/common/ (made if missing). Environment: DSNAKE (default
# build/release/experiments/dsnake), STRUCTURES (default the thirteen, "NAME LEFT RIGHT;...").
set -euo pipefail
cd "$(dirname "$0")/../../.."
export DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
WHAT=${1:-all}
STRUCTURES=${STRUCTURES:-"precuneus 67 68;angular 65 66;rolandic 17 18;sma 19 20;midcing 33 34;crus1 91 92;insula 29 30;parahipp 39 40;heschl 79 80;olfactory 21 22;postcing 35 36;tpole 83 84;flocculus 107 108"}
IN=data/real/anatomy/more
OUT=out/real/anatomy/more
mkdir -p "$IN" "$OUT"
[ -f data/real/anatomy/inputs.json ] || nice /usr/bin/python3 experiments/real/anatomy/make_inputs.py "$DSNAKE" .
NAMES=()
IFS=';' read -ra ENTRIES <<<"$STRUCTURES"
for e in "${ENTRIES[@]}"; do
  read -r name left right <<<"$e"
  [ -f "$IN/$name/template.off" ] || /usr/bin/python3 experiments/real/anatomy/make_mirror_case.py "$DSNAKE" "$IN" "$name" "$left" "$right"
  NAMES+=("$name")
done

dsnake_stream() {
  for c in "${NAMES[@]}"; do
    d=$(realpath "$IN/$c")
    for m in recipe noref; do
      [ -f "$OUT/$c/$m/result.json" ] && continue
      mkdir -p "$OUT/$c"
      ref=(--reference "$d/reference.nii.gz")
      [ $m = noref ] && ref=()
      "$DSNAKE" init --image "$d/image.nii.gz" --template "$d/template.off" "${ref[@]}" --mask "$d/truth.nii.gz" \
        --name "$c" >"$OUT/$c/$m.json" 2>/dev/null
      nice "$DSNAKE" run "$OUT/$c/$m.json" --out "$OUT/$c/$m" -j 1 -q --set output.start_metrics=true ||
        echo "run_more: dsnake $m on $c failed"
    done
  done
}

peer_stream() {  # peer_stream elastix | syn
  for c in "${NAMES[@]}"; do
    d=$IN/$c
    [ -f "$OUT/$c/$1/summary.json" ] && continue
    echo "== $1 $c"
    if [ "$1" = elastix ]; then
      VERTICES=2000 THREADS=1 nice bash experiments/real/elastix.sh "$d/image.nii.gz" "$d/reference.nii.gz" \
        "$d/template.off" "$d/truth.nii.gz" "$OUT/$c/elastix" || echo "run_more: elastix on $c failed"
    else
      VERTICES=2000 THREADS=1 nice /usr/bin/python3 experiments/real/syn.py "$d/image.nii.gz" "$d/reference.nii.gz" \
        "$d/template.off" "$d/truth.nii.gz" "$OUT/$c/syn" || echo "run_more: SyN on $c failed"
    fi
  done
}

case $WHAT in
  dsnake) dsnake_stream ;;
  peers) peer_stream elastix; peer_stream syn ;;
  all)
    { dsnake_stream; peer_stream syn; } >"$OUT/dsnake_syn.log" 2>&1 &
    a=$!
    peer_stream elastix >"$OUT/elastix.log" 2>&1 &
    b=$!
    wait $a $b ;;
  table) ;;
  *) echo "usage: run_more.sh [all | dsnake | peers | table]" >&2; exit 2 ;;
esac

/usr/bin/python3 - "$OUT" "${NAMES[@]}" <<'EOF'
import json, os, sys
out, names = sys.argv[1], sys.argv[2:]
def load(p):
    return json.load(open(p)) if os.path.exists(p) else None
f = lambda x: "-" if x is None else f"{x:.3f}"
print(f"Dice against the left label ({out}); start: after the affine init; bold: at least the best of the start, elastix and SyN")
print()
print("| case | start | recipe | elastix | SyN | without atlas: start -> end |")
print("| --- | --- | --- | --- | --- | --- |")
for c in names:
    r, n = load(f"{out}/{c}/recipe/result.json"), load(f"{out}/{c}/noref/result.json")
    e, y = load(f"{out}/{c}/elastix/summary.json"), load(f"{out}/{c}/syn/summary.json")
    s = r["start"]["metrics"]["dice"] if r else None
    d = r["metrics"]["dice"] if r else None
    ed = e["metrics"]["dice"] if e else None
    yd = y["metrics"]["dice"] if y else None
    known = [v for v in (s, ed, yd) if v is not None]
    b = "**" if d is not None and known and d >= max(known) - 5e-4 else ""
    ns = f(n["start"]["metrics"]["dice"]) + " -> " + f(n["metrics"]["dice"]) if n else "-"
    print(f"| {c} | {f(s)} | {b}{f(d)}{b} | {f(ed)} | {f(yd)} | {ns} |")
EOF
