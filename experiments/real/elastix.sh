#!/bin/bash
# The peer of the real-scan experiments (REPRODUCTION.md): atlas registration with elastix (affine, then B-spline;
# experiments/real/elastix_affine.txt and elastix_bspline.txt), its result measured exactly as
# dsnake's results are.
#
#   experiments/real/elastix.sh CASE                  (liver, femur: data/real/CASE/ from
#                                                     make_3d_inputs.py; lung: make_2d_inputs.py)
#   experiments/real/elastix.sh FIXED MOVING TEMPLATE GROUND_TRUTH OUT
#
# FIXED is the scan, MOVING the atlas (reference) image in which TEMPLATE (a mesh, or a 2D contour
# .txt) sits on its object, GROUND_TRUTH the true mask on FIXED's grid. Steps, into OUT
# (default out/real/CASE/elastix):
#   1. the template's mask in the moving space: result_mask.nii.gz of a 0-iteration dsnake run
#      whose image is MOVING;
#   2. elastix FIXED <- MOVING (affine, then B-spline), under /usr/bin/time (wall, peak memory);
#   3. transformix warps the mask with linear interpolation (FinalBSplineInterpolationOrder 1, as
#      float), thresholded at 0.5 (a nearest-neighbour warp would carry the mask's voxel staircase
#      off the grid, where no surface follows it; experiments/real/anatomy/make_inputs.py);
#   4. `dsnake template --mask` makes a surface (3D: VERTICES, default 3000) or contour (2D: VERTICES,
#      default 128) of the warped mask (at the surface's own vertex count when it has fewer);
#   5. a 0-iteration dsnake run evaluates it against GROUND_TRUTH (Dice, mean surface distance,
#      HD95, self-intersections: the metrics of dsnake's own runs);
#   6. (3D) the template's vertices carried into the fixed space by the inverse of elastix's transform
#      (experiments/real/elastix_points.py: transformix maps fixed-space points to moving-space
#      points, the template sits in the moving space, so T^-1 by a fixed-point iteration over
#      transformix -def calls), then measured by a 0-iteration dsnake run: the same metrics, at the
#      template's resolution, as dsnake's result has, and with CORRESPONDENCE (a
#      ground_truth.correspondence file for TEMPLATE's vertices) their distances to their truth
#      (correspondence_error_mean, _max).
# Environment: DSNAKE (default build/release/experiments/dsnake), THREADS (elastix's and dsnake's
# threads, default 2), VERTICES, CORRESPONDENCE.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
THREADS=${THREADS:-2}
PAR=$ROOT/experiments/real

if [ $# -eq 1 ]; then
  CASE=$1
  OUT=out/real/$CASE/elastix
  case $CASE in
    liver | femur)
      [ -f data/real/$CASE/inputs.json ] || /usr/bin/python3 experiments/real/make_3d_inputs.py "$DSNAKE" . "$CASE"
      set -- data/real/$CASE/image.mha data/real/$CASE/reference.mha data/real/$CASE/template.off data/real/$CASE/truth.mha "$OUT" ;;
    lung)
      [ -f data/real/lung/template.txt ] || /usr/bin/python3 experiments/real/make_2d_inputs.py "$DSNAKE" .
      set -- data/scans/itk/RatLungSlice2.mha data/scans/itk/RatLungSlice1.mha data/real/lung/template.txt data/real/lung/slice2_mask.mha "$OUT" ;;
    *) echo "elastix.sh: unknown case $CASE (liver, femur, lung; or give FIXED MOVING TEMPLATE GROUND_TRUTH OUT)" >&2; exit 2 ;;
  esac
fi
[ $# -eq 5 ] || { echo "usage: elastix.sh CASE | FIXED MOVING TEMPLATE GROUND_TRUTH OUT" >&2; exit 2; }
FIXED=$(realpath "$1"); MOVING=$(realpath "$2"); TEMPLATE=$(realpath "$3"); TRUTH=$(realpath "$4"); OUT=$5
case $TEMPLATE in *.txt | *.json) DIM=2; EXT=txt; VERTICES=${VERTICES:-128} ;; *) DIM=3; EXT=off; VERTICES=${VERTICES:-3000} ;; esac
rm -rf "$OUT"
mkdir -p "$OUT/elastix" "$OUT/transformix"
OUT=$(realpath "$OUT")

zero_run() {  # zero_run NAME IMAGE TEMPLATE [TRUTH [CORRESPONDENCE]]: a 0-iteration dsnake run into OUT/NAME
  local truth=""
  [ -n "${4:-}" ] && truth=", \"ground_truth\": {\"mask\": \"$4\"}"
  [ -n "${5:-}" ] && truth=", \"ground_truth\": {\"mask\": \"$4\", \"correspondence\": \"$5\"}"
  cat >"$OUT/$1.json" <<EOF
{"dimension": $DIM, "name": "$1", "image": {"file": "$2"}, "template": {"file": "$3"}$truth,
 "field": {"type": "gradient"}, "energies": [{"type": "internal", "weight": 1.0}],
 "phases": [{"iterations": 0}], "output": {"figures": true}}
EOF
  "$DSNAKE" run "$OUT/$1.json" --out "$OUT/$1" --quiet -j "$THREADS"
}

# 1. the template's mask where the template sits: on the moving (atlas) image's grid
zero_run moving_mask "$MOVING" "$TEMPLATE"

# 2. elastix
/usr/bin/time -f "%e %M" -o "$OUT/elastix_time.txt" \
  elastix -f "$FIXED" -m "$MOVING" -p "$PAR/elastix_affine.txt" -p "$PAR/elastix_bspline.txt" \
  -out "$OUT/elastix" -threads "$THREADS" >"$OUT/elastix.log" 2>&1

# 3. transformix: the mask, linearly interpolated as float, then thresholded at 0.5
for k in 0 1; do
  sed -e 's/^(FinalBSplineInterpolationOrder .*)/(FinalBSplineInterpolationOrder 1)/' \
      -e 's/^(ResultImagePixelType .*)/(ResultImagePixelType "float")/' \
      -e 's/^(ResultImageFormat .*)/(ResultImageFormat "nii.gz")/' \
      -e "s|^(InitialTransformParametersFileName .*)|(InitialTransformParametersFileName \"$( [ $k = 1 ] && echo "$OUT/transformix/TransformParameters.0.txt" || echo NoInitialTransform)\")|" \
      "$OUT/elastix/TransformParameters.$k.txt" >"$OUT/transformix/TransformParameters.$k.txt"
done
/usr/bin/time -f "%e %M" -o "$OUT/transformix_time.txt" \
  transformix -in "$OUT/moving_mask/result_mask.nii.gz" -tp "$OUT/transformix/TransformParameters.1.txt" \
  -out "$OUT/transformix" -threads "$THREADS" >"$OUT/transformix.log" 2>&1
/usr/bin/python3 - "$OUT/transformix/result.nii.gz" "$OUT/transformix/result_mask.nii.gz" <<'EOF'
import sys
import nibabel as nib
import numpy as np
img = nib.load(sys.argv[1])
mask = (np.asarray(img.dataobj) >= 0.5).astype(np.uint8)
out = nib.Nifti1Image(mask, img.affine, img.header)
out.set_data_dtype(np.uint8)
out.header["scl_slope"], out.header["scl_inter"] = 1.0, 0.0
nib.save(out, sys.argv[2])
EOF

# 4. a surface (contour) of the warped mask
# (a small mask's surface with fewer vertices than VERTICES: the surface at its own count)
if ! "$DSNAKE" template --mask "$OUT/transformix/result_mask.nii.gz" --label 1 --vertices "$VERTICES" \
  --out "$OUT/elastix_result.$EXT" -j "$THREADS" >"$OUT/template.log" 2>"$OUT/template.err"; then
  fewer=$(sed -n 's/.*more than the \([0-9]*\) vertices of the surface.*/\1/p' "$OUT/template.err")
  [ -n "$fewer" ] || { cat "$OUT/template.err" >&2; exit 1; }
  cat "$OUT/template.err"
  "$DSNAKE" template --mask "$OUT/transformix/result_mask.nii.gz" --label 1 --vertices "$fewer" \
    --out "$OUT/elastix_result.$EXT" -j "$THREADS" >"$OUT/template.log"
fi

# 5. measured as dsnake's runs are
zero_run evaluate "$FIXED" "$OUT/elastix_result.$EXT" "$TRUTH"

# 6. the template's vertices through the inverse transform, against their true positions
if [ $DIM = 3 ]; then
  /usr/bin/time -f "%e %M" -o "$OUT/points_time.txt" /usr/bin/python3 "$PAR/elastix_points.py" \
    "$OUT/transformix/TransformParameters.1.txt" "$TEMPLATE" "$OUT/elastix_points.off" "$THREADS" >"$OUT/points.log"
  # (a failed registration can fold the template onto itself: dsnake refuses it, and the
  # summary then has no carried_template_metrics)
  zero_run correspondence "$FIXED" "$OUT/elastix_points.off" "$TRUTH" ${CORRESPONDENCE:+"$(realpath "$CORRESPONDENCE")"} ||
    echo "elastix.sh: the template carried by elastix's transform was refused (above)" >&2
fi

/usr/bin/python3 - "$OUT" <<'EOF'
import json, sys
out = sys.argv[1]
m = json.load(open(f"{out}/evaluate/result.json"))["metrics"]
wall, kb = open(f"{out}/elastix_time.txt").read().split()[-2:]
twall, tkb = open(f"{out}/transformix_time.txt").read().split()[-2:]
print(open(f"{out}/template.log").read().strip())
print(f"elastix (affine + B-spline): Dice {m['dice']:.4f}, mean surface distance {m['mean_surface_distance']:.3f} mm, "
      f"HD95 {m['hausdorff95']:.3f} mm, self-intersections {m['self_intersections']}; elastix {float(wall):.1f} s wall, "
      f"{int(kb) / 1024:.0f} MB peak; transformix {float(twall):.1f} s, {int(tkb) / 1024:.0f} MB")
summary = {"metrics": m, "elastix_wall_s": float(wall), "elastix_peak_mb": int(kb) / 1024,
           "transformix_wall_s": float(twall), "transformix_peak_mb": int(tkb) / 1024}
try:
    cm = json.load(open(f"{out}/correspondence/result.json"))["metrics"]
    pwall, pkb = open(f"{out}/points_time.txt").read().split()[-2:]
    print(open(f"{out}/points.log").read().strip())
    summary.update(carried_template_metrics=cm, points_wall_s=float(pwall))
    print(f"template vertices through T^-1: Dice {cm['dice']:.4f} ({float(pwall):.1f} s)")
    if cm.get("correspondence_error_mean") is not None:  # null without ground_truth.correspondence
        print(f"  correspondence error mean {cm['correspondence_error_mean']:.3f} mm, "
              f"max {cm['correspondence_error_max']:.3f} mm")
        summary.update(correspondence_error_mean=cm["correspondence_error_mean"],
                       correspondence_error_max=cm["correspondence_error_max"])
except FileNotFoundError:
    pass
json.dump(summary, open(f"{out}/summary.json", "w"), indent=1)
EOF
