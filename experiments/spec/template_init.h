// "template.init" (ours; the paper's §9 future work): a pre-alignment of the placed template
// before the snake, applied after "template.transform" (so a rough placement can still be given,
// and it settles the moments' axis ambiguity) and before anything runs. The map found is a
// similarity (or a rigid motion) in world coordinates (LPS mm), applied to the placed template:
//  - "moments": the template's enclosed area/volume moments (framework/core/alignment.h: exact for
//    the polygon or mesh, whatever its resolution) matched to the voxel moments of a label image
//    ("mask", the voxels equal to "label", or non-zero) or of the experiment's image within
//    "threshold" [lo, hi] (after its corruptions; every voxel in range, not one component):
//    centroids matched, the scale (uniform) from the measure ratio, the rotation from the
//    principal axes, the proper rotation closest to the identity among those that match them;
//    near-isotropic axes keep the template's orientation (align_moments()).
//  - "landmarks": the least-squares similarity taking the template's named landmarks
//    (template.landmarks) onto "points" (world mm; 2D at least 2 pairs, 3D at least 3 not on one
//    line: the fewest that determine a similarity).
//  - "image": template.reference_image (the atlas in which the template's file positions lie on
//    the object) registered onto the experiment's image within the template's bounding box plus
//    "margin", by normalised cross-correlation over Gaussian "levels" (mm), starting from the
//    placement (framework/core/image_alignment.h). The found map T (reference world -> scan
//    world) gives the template at T p; the map applied to the placed template is T o P^-1 (P the
//    placement), rigid, similar or (this type only) affine.
//    With "whole_image" (rigid, similarity or affine; "none" by default) the whole reference is
//    first registered onto the whole scan, from the placement moved so that the two images'
//    foreground centroids (the voxels brighter than the image's mean) coincide, over the coarse
//    "whole_image_levels": the scan of another subject may lie anywhere in its scanner's world,
//    tens of mm and degrees from the atlas, beyond what the region's own registration captures
//    (§9: initialisation, the open problem). The region's registration then runs from that
//    result and from the placement, and the one with the higher NCC over the region is kept (so
//    a placement that is already right is not given up for a whole-image fit that is not).
// "transform": "rigid" keeps the scale 1 in all. result.json's "init" reports the map and the
// fit (init_report_json()).
#pragma once

#include "framework/core/alignment.h"
#include "framework/core/image_alignment.h"
#include "framework/core/shape.h"
#include "framework/core/options.h"

#include <map>
#include <nlohmann/json.hpp>
#include "framework/io/image_io.h"

#include <optional>
#include <string>
#include <vector>

namespace dsnake {

enum class TemplateInitType { kMoments, kLandmarks, kImage };
// The whole-image stage of type image: none, or the model of the whole reference's alignment.
enum class WholeImageModel { kNone, kRigid, kSimilarity, kAffine };
template <>
struct EnumNames<WholeImageModel> {
  static constexpr std::array<std::pair<WholeImageModel, const char*>, 4> table{
      {{WholeImageModel::kNone, "none"}, {WholeImageModel::kRigid, "rigid"}, {WholeImageModel::kSimilarity, "similarity"}, {WholeImageModel::kAffine, "affine"}}};
};
template <>
struct EnumNames<TemplateInitType> {
  static constexpr std::array<std::pair<TemplateInitType, const char*>, 3> table{
      {{TemplateInitType::kMoments, "moments"}, {TemplateInitType::kLandmarks, "landmarks"}, {TemplateInitType::kImage, "image"}}};
};

struct TemplateInitOptions {
  TemplateInitType type = TemplateInitType::kMoments;
  std::string mask;               // moments: a label image (resolved against the experiment's folder)
  std::optional<int> label;       // moments with a mask: the label that is inside (default: non-zero)
  std::vector<double> threshold;  // moments: [lo, hi] on the experiment's image
  double isotropy_tolerance = 0.05;
  NamedPoints points;             // landmarks: name -> world point
  AlignmentModel transform = AlignmentModel::kSimilarity;
  double margin = 10.0;                          // image: mm around the template's bounding box
  std::vector<double> levels = {4.0, 2.0, 1.0};  // image: smoothing sigmas (mm), coarse to fine
  int iterations = 50;                           // image: steps per level at most
  double max_scale = 1.5;                        // image: bound on the result's scale against the start's
  WholeImageModel whole_image = WholeImageModel::kNone;  // image: the whole reference onto the whole scan first
  std::vector<double> whole_image_levels = {8.0, 4.0};    // image: its smoothing sigmas (mm), coarse to fine
  ImageReadOptions mask_read;     // how `mask` is read: the experiment's image.nifti_transform (not a key here)

  template <class V>
  void visit(V& v) {
    v(type, Key{"type", "", "moments: match centroid, principal axes and area/volume to a region; landmarks: the least-squares similarity of named point pairs; image: register template.reference_image onto the image by normalised cross-correlation within the template's region (required)"});
    v(mask, Key{"mask", "", "moments: a label image (any grid; world coordinates); exactly one of mask and threshold"});
    v(label, Key{"label", "", "moments with a mask: the voxel value that is inside (default: every non-zero voxel)"});
    v(threshold, Key{"threshold", "image intensity", "moments: [lo, hi], the voxels of the experiment's image (after corruptions) within it are the region"});
    v(isotropy_tolerance, Key{"isotropy_tolerance", "1 (relative)", "moments: eigenvalues of the covariance closer than this times the largest leave their axes undetermined (near-isotropic: the template's orientation is kept)", Range::closed_open(0, 1)});
    v(points, Key{"points", "mm (world, LPS)", "landmarks: {\"name\": [x, y(, z)]} for named template landmarks; 2D >= 2 pairs, 3D >= 3 not on one line"});
    v(transform, Key{"transform", "", "a similarity (rotation, translation, uniform scale), a rigid motion (scale 1) or, for image only, an affine map (a general matrix)"});
    v(margin, Key{"margin", "mm", "image: added to every side of the template's bounding box (in the reference image) to make the region compared", Range::at_least(0)});
    v(levels, Key{"levels", "mm", "image: Gaussian smoothing (standard deviation) of both images per level, coarse to fine, each >= 0; samples every round(sigma / spacing) voxels"});
    v(iterations, Key{"iterations", "", "image: Levenberg-Marquardt steps per level at most", Range::at_least(1)});
    v(whole_image, Key{"whole_image", "", "image: first register the whole reference image onto the whole scan with this model (rigid, similarity or affine), from the placement moved so that their foreground centroids (voxels brighter than each image's mean) coincide; the region's registration then runs from that result and from the placement and keeps the one with the higher NCC over the region (for a scan that lies tens of mm or degrees from the atlas in world coordinates, e.g. in its scanner's frame); none: the region's registration from the placement only"});
    v(whole_image_levels, Key{"whole_image_levels", "mm", "image with whole_image: Gaussian smoothing (standard deviation) of both whole images per level, coarse to fine, each >= 0"});
    v(max_scale, Key{"max_scale", "1 (ratio)", "image: the result's scale relative to the placed template's, along every axis (the singular values of its linear part after the placement's inverse; one value for a similarity), must lie within [1 / max_scale, max_scale], else the start is kept with a warning: NCC over the template's region can rise by mapping it onto a small part of the scan or squashing it along one axis, and an atlas of the same species is not that much larger or smaller, nor that much longer in one direction (0: no bound)", Range::at_least(0)});
  }
  // The alignment options of type image: the region's, and the whole image's (margin 0).
  ImageAlignmentOptions alignment() const;
  ImageAlignmentOptions whole_image_alignment() const;
  // The keys of one type only (OptionError naming the key).
  void check() const;
};

// What the init did: the world map x -> s R x + t (moments, landmarks; image with rigid or
// similarity) or x -> A x + t (`map`, every type) applied to the placed template, and the fit.
template <int D>
struct InitReport {
  TemplateInitType type = TemplateInitType::kMoments;
  AlignmentModel model = AlignmentModel::kSimilarity;
  Similarity<D> transform;  // the map when it is a similarity (image with affine: its nearest, unused)
  AffineMap<D> map;         // the map, always
  ImageAlignmentResult<D> alignment;  // image: the fit (alignment.transform: reference world -> image world)
  // image with whole_image: the whole reference's fit (from the centroids' match), and whether
  // the region's registration kept the start it gave (else the placement's)
  std::optional<ImageAlignmentResult<D>> whole_image;
  Point<D> centroid_shift = Point<D>::Zero();  // scan's foreground centroid minus the placed reference's
  bool from_whole_image = false;
  Moments<D> template_moments, target_moments;  // moments
  int axes_matched = 0;                         // moments: D, 1 (3D) or 0
  std::map<std::string, double> residuals;      // landmarks: |S(p_l) - y_l| per name, mm
  double residual_rms = 0.0, residual_max = 0.0;
};

// Applies the init to `placed` (the placed template in world coordinates, one point per
// template id). `image` is the experiment's image (for "threshold", and the moving image of
// "image"); `reference` is template.reference_image (required by "image"). Throws InputError
// naming `file` and the JSON path ("template.init.points.tip") for unknown names, too few or
// degenerate pairs, empty regions and a missing reference image. An image alignment that keeps
// its start (no overlap, no improvement) prints its warning on stderr and reports it.
template <int D>
InitReport<D> initialize_template(const TemplateInitOptions& options, const Template<D>& tmpl, const Image<D>& image,
                                  PointList<D>& placed, const std::string& file, const Image<D>* reference = nullptr);

// result.json's "init": type, scale, rotation (matrix, and the angle in degrees; 3D also the
// axis), translation (mm) and, for landmarks, the residuals (mm), for moments the two measures
// and centroids and the axes matched; for image the matrix (and, rigid or similarity, the scale
// and rotation), the NCC before and after, the iterations and each level, and with whole_image
// its fit ("whole_image": the centroids' shift, its map reference world -> scan world as matrix
// and translation, NCC, levels, and "kept": whether the region's registration started from it).
template <int D>
nlohmann::ordered_json init_report_json(const InitReport<D>& report);

}  // namespace dsnake
