// "template.init" (issue 20; the paper's §9 future work): a pre-alignment of the placed template
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
//    line: the fewest that determine a similarity; the issue asks for 3, the 2D minimum is 2).
// "transform": "rigid" keeps the scale 1 in both. result.json's "init" reports the map and the
// fit (init_report_json()).
#pragma once

#include "energies/similarity.h"
#include "framework/core/alignment.h"
#include "framework/core/options.h"

#include <map>
#include <nlohmann/json.hpp>
#include "framework/io/image_io.h"

#include <optional>
#include <string>
#include <vector>

namespace dsnake {

enum class TemplateInitType { kMoments, kLandmarks };
template <>
struct EnumNames<TemplateInitType> {
  static constexpr std::array<std::pair<TemplateInitType, const char*>, 2> table{
      {{TemplateInitType::kMoments, "moments"}, {TemplateInitType::kLandmarks, "landmarks"}}};
};

struct TemplateInitOptions {
  TemplateInitType type = TemplateInitType::kMoments;
  std::string mask;               // moments: a label image (resolved against the experiment's folder)
  std::optional<int> label;       // moments with a mask: the label that is inside (default: non-zero)
  std::vector<double> threshold;  // moments: [lo, hi] on the experiment's image
  double isotropy_tolerance = 0.05;
  NamedPoints points;             // landmarks: name -> world point
  SimilarityTransform transform = SimilarityTransform::kSimilarity;
  ImageReadOptions mask_read;     // how `mask` is read: the experiment's image.nifti_transform (not a key here)

  template <class V>
  void visit(V& v) {
    v(type, Key{"type", "", "moments: match centroid, principal axes and area/volume to a region; landmarks: the least-squares similarity of named point pairs (required)"});
    v(mask, Key{"mask", "", "moments: a label image (any grid; world coordinates); exactly one of mask and threshold"});
    v(label, Key{"label", "", "moments with a mask: the voxel value that is inside (default: every non-zero voxel)"});
    v(threshold, Key{"threshold", "image intensity", "moments: [lo, hi], the voxels of the experiment's image (after corruptions) within it are the region"});
    v(isotropy_tolerance, Key{"isotropy_tolerance", "1 (relative)", "moments: eigenvalues of the covariance closer than this times the largest leave their axes undetermined (near-isotropic: the template's orientation is kept)", Range::closed_open(0, 1)});
    v(points, Key{"points", "mm (world, LPS)", "landmarks: {\"name\": [x, y(, z)]} for named template landmarks; 2D >= 2 pairs, 3D >= 3 not on one line"});
    v(transform, Key{"transform", "", "a similarity (rotation, translation, uniform scale) or a rigid motion (scale 1)"});
  }
  // The keys of one type only (OptionError naming the key).
  void check() const;
};

// What the init did: the world map x -> s R x + t applied to the placed template, and the fit.
template <int D>
struct InitReport {
  TemplateInitType type = TemplateInitType::kMoments;
  Similarity<D> transform;
  Moments<D> template_moments, target_moments;  // moments
  int axes_matched = 0;                         // moments: D, 1 (3D) or 0
  std::map<std::string, double> residuals;      // landmarks: |S(p_l) - y_l| per name, mm
  double residual_rms = 0.0, residual_max = 0.0;
};

// Applies the init to `placed` (the placed template in world coordinates, one point per
// template id). `image` is the experiment's image (for "threshold"). Throws InputError naming
// `file` and the JSON path ("template.init.points.tip") for unknown names, too few or degenerate
// pairs and empty regions.
template <int D>
InitReport<D> initialize_template(const TemplateInitOptions& options, const Template<D>& tmpl, const Image<D>& image,
                                  PointList<D>& placed, const std::string& file);

// result.json's "init": type, scale, rotation (matrix, and the angle in degrees; 3D also the
// axis), translation (mm) and, for landmarks, the residuals (mm), for moments the two measures
// and centroids and the axes matched.
template <int D>
nlohmann::ordered_json init_report_json(const InitReport<D>& report);

}  // namespace dsnake
