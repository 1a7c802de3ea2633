#!/bin/bash
# The mirror and cross-contrast cases in 2D (REPRODUCTION.md, "Two dimensions with an atlas image"):
# each case's axial slice where its truth is largest (make_slice_case.py), registered by
#   with_atlas:  `dsnake init --reference` as printed (recipe_2d_with_atlas.json),
#   profile:     recipe_2d.json with the same atlas image (the 2D recipe before it),
#   without:     `dsnake init` without --reference as printed (recipe_2d_without_atlas.json),
#   one polarity: recipe_2d.json (one polarity learned at the start, no atlas; the corpus callosum's),
#   elastix:     experiments/real/elastix.sh (affine + B-spline, the template's mask warped),
#   SyN:         experiments/real/syn.py (dipy's MI affine + CC SyN in 2D, the template's mask warped),
# and the six development cases' fixed points (the truth's surface cut; with atlas: the slice its own
# atlas; without: as printed without --reference).
#   bash experiments/real/anatomy/run_slices.sh        (needs data/real/anatomy and its more/ cases:
#                                                       make_inputs.py, run_more.sh)
# AXIS=y: coronal slices instead (out/real/anatomy/slices_coronal/). Prints one row per case: Dice at the start -> at the end (start: the placed template, or after
# the image init for with_atlas). One thread per run; out/real/anatomy/slices/CASE/.
set -euo pipefail
cd "$(dirname "$0")/../../.."
DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
PYTHON=${PYTHON:-/usr/bin/python3}
A=data/real/anatomy
AXIS=${AXIS:-z}
OUT=out/real/anatomy/slices$([ "$AXIS" = y ] && echo _coronal || true)
DEV="amygdala_mirror pallidum_mirror cerebellum_mirror amygdala_cross pallidum_cross cerebellum_cross"
MORE="precuneus angular rolandic sma midcing crus1 insula parahipp heschl olfactory postcing tpole flocculus"
dice() {  # dice RUN_DIR: "start -> end"
  "$PYTHON" -c "import json,sys; r=json.load(open(sys.argv[1]+'/result.json')); print('%.3f -> %.3f' % (r.get('start',{}).get('metrics',{}).get('dice',float('nan')), r['metrics']['dice']))" "$1"
}
run() {  # run DIR TAG EXPERIMENT [--set ...]
  local d=$1 t=$2 e=$3; shift 3
  "$DSNAKE" run "$e" --out "$d/$t" -j 1 --quiet --set output.start_metrics=true "$@" > "$d/$t.log" 2>&1
}
printf '| case | with atlas | profile, same atlas | without atlas | one polarity, no atlas | elastix | SyN | fixed point: with / without atlas |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n'
for c in $DEV $MORE; do
  src=$A/$c; [ -d "$src" ] || src=$A/more/$c
  d=$OUT/$c; mkdir -p "$d"
  "$PYTHON" experiments/real/anatomy/make_slice_case.py "$src" "$d/in" --axis $AXIS > /dev/null
  i=$d/in
  "$DSNAKE" init --image $i/image.nii.gz --template $i/template.txt --reference $i/reference.nii.gz --mask $i/truth.nii.gz --name $c > $d/with_atlas.json 2> /dev/null
  run $d with_atlas $d/with_atlas.json
  run $d profile experiments/real/recipe_2d.json --set image.file=$(realpath $i/image.nii.gz) --set template.file=$(realpath $i/template.txt) \
    --set template.reference_image=$(realpath $i/reference.nii.gz) --set ground_truth.mask=$(realpath $i/truth.nii.gz)
  "$DSNAKE" init --image $i/image.nii.gz --template $i/template.txt --mask $i/truth.nii.gz --name $c > $d/without.json 2> /dev/null
  run $d without $d/without.json
  run $d one_polarity experiments/real/recipe_2d.json --set image.file=$(realpath $i/image.nii.gz) --set template.file=$(realpath $i/template.txt) \
    --set ground_truth.mask=$(realpath $i/truth.nii.gz)
  VERTICES=128 THREADS=1 DSNAKE=$DSNAKE bash experiments/real/elastix.sh $i/image.nii.gz $i/reference.nii.gz $i/template.txt $i/truth.nii.gz $d/elastix > $d/elastix.log 2>&1
  el=$(sed -n 's/.*Dice \([0-9.]*\),.*/\1/p' $d/elastix.log | tail -1)
  VERTICES=128 THREADS=1 DSNAKE=$DSNAKE "$PYTHON" experiments/real/syn.py $i/image.nii.gz $i/reference.nii.gz $i/template.txt $i/truth.nii.gz $d/syn > $d/syn.log 2>&1
  syn=$(sed -n 's/.*Dice \([0-9.]*\),.*/\1/p' $d/syn.log | tail -1)
  fp="–"
  if [ -f "$src/fixed_template.off" ]; then
    "$PYTHON" experiments/real/anatomy/make_slice_case.py "$src" "$d/fp_in" --template fixed_template.off --axis $AXIS > /dev/null
    f=$d/fp_in
    run $d fixed_point experiments/real/recipe_2d_with_atlas.json --set image.file=$(realpath $f/image.nii.gz) --set template.file=$(realpath $f/template.txt) \
      --set template.reference_image=$(realpath $f/image.nii.gz) --set ground_truth.mask=$(realpath $f/truth.nii.gz)
    "$DSNAKE" init --image $f/image.nii.gz --template $f/template.txt --mask $f/truth.nii.gz --name $c > $d/fixed_point_without.json 2> /dev/null
    run $d fixed_point_without $d/fixed_point_without.json
    fp="$(dice $d/fixed_point) / $(dice $d/fixed_point_without)"
  fi
  printf '| %s | %s | %s | %s | %s | %.3f | %.3f | %s |\n' $c "$(dice $d/with_atlas)" "$(dice $d/profile)" "$(dice $d/without)" "$(dice $d/one_polarity)" "$el" "$syn" "$fp"
done
