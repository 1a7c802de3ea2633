// Intensity-based alignment of an atlas (reference) image onto a scan within a region: the
// rigid, similarity or affine world map T that maximises the normalised cross-correlation (NCC)
// of R(x) and S(T x) over the region's voxels x of R. Written as variable-projection least
// squares (Golub & Pereyra 1973; Kaufman 1975),
//   min over theta, a, b of  sum_i (R(x_i) - a S(T_theta x_i) - b)^2,
// whose minimum over the contrast a and offset b (closed form, a linear fit) is
// sum_i (R_i - mean R)^2 (1 - NCC^2): robust to a linear change of contrast between the images.
// theta is solved by Levenberg-Marquardt on the forward-compositional Gauss-Newton model of
// Lucas-Kanade image alignment (Baker & Matthews, IJCV 2004), with the analytic Jacobian from
// the gradient of the smoothed moving image, coarse to fine over Gaussian smoothing levels (mm).
// Serial or blocked sums in a fixed order: the same bits for any thread count. Pure images and
// maps: experiments/spec/template_init.h reads the experiment keys and applies the result.
#pragma once

#include "framework/core/image.h"
#include "framework/core/options.h"

#include <string>
#include <vector>

namespace dsnake {

// The transformation model: rotation and translation; with a uniform scale; a general matrix.
enum class AlignmentModel { kSimilarity, kRigid, kAffine };
template <>
struct EnumNames<AlignmentModel> {
  static constexpr std::array<std::pair<AlignmentModel, const char*>, 3> table{
      {{AlignmentModel::kSimilarity, "similarity"}, {AlignmentModel::kRigid, "rigid"}, {AlignmentModel::kAffine, "affine"}}};
};

// x -> matrix x + translation (world mm; matrix D x D, any invertible one).
template <int D>
struct AffineMap {
  Eigen::Matrix<double, D, D> matrix = Eigen::Matrix<double, D, D>::Identity();
  Point<D> translation = Point<D>::Zero();
  Point<D> apply(const Point<D>& x) const { return Point<D>(matrix * x + translation); }
  AffineMap inverse() const {
    AffineMap m;
    m.matrix = matrix.inverse();
    m.translation = -(m.matrix * translation);
    return m;
  }
  AffineMap after(const AffineMap& first) const {  // this o first
    AffineMap m;
    m.matrix = matrix * first.matrix;
    m.translation = matrix * first.translation + translation;
    return m;
  }
};

// An axis-aligned box in world mm, lo <= hi per axis.
template <int D>
struct WorldBox {
  Point<D> lo = Point<D>::Zero(), hi = Point<D>::Zero();
};

struct ImageAlignmentOptions {
  AlignmentModel model = AlignmentModel::kSimilarity;
  double margin = 10.0;                       // mm added to every side of the region
  std::vector<double> levels = {4.0, 2.0, 1.0};  // Gaussian sigmas (mm), coarse to fine; 0: no smoothing
  int iterations = 50;                        // Levenberg-Marquardt steps per level at most
  double tolerance = 1e-3;                    // mm: a level ends when a step moves no region corner further
  double min_overlap = 0.8;                   // a step keeping less than this share of the start's overlap is refused
  // The result's scale relative to the start's along every axis (the singular values of its
  // linear part after the start's inverse: one value for a similarity) must lie within
  // [1 / max_scale, max_scale], else the start is kept: NCC over a region of the fixed image can
  // rise by mapping that region onto a small part of the moving one (or squashing it along one
  // axis), and an atlas of the same species is not several times larger or smaller than the scan,
  // nor several times longer in one direction. 0: no bound.
  double max_scale = 1.5;

  template <class V>
  void visit(V& v) {
    v(model, Key{"transform", "", "the model: similarity (rotation, translation, uniform scale), rigid or affine (a general matrix)"});
    v(margin, Key{"margin", "mm", "added to every side of the region", Range::at_least(0)});
    v(levels, Key{"levels", "mm", "Gaussian smoothing of both images per level, coarse to fine"});
    v(iterations, Key{"iterations", "", "Levenberg-Marquardt steps per level at most", Range::at_least(1)});
    v(tolerance, Key{"tolerance", "mm", "a level ends when a step moves no corner of the region further", Range::greater_than(0)});
    v(min_overlap, Key{"min_overlap", "1 (relative)", "a step is refused when the share of the region inside the moving image drops below this times the start's", Range::closed(0, 1)});
    v(max_scale, Key{"max_scale", "1 (ratio)", "the result's scale relative to the start's, along every axis (an affine's singular values), must lie within [1 / max_scale, max_scale], else the start is kept (0: no bound)", Range::at_least(0)});
  }
  void check() const;
};

// One smoothing level: its sigma (mm), its sample stride (voxels per axis, the largest), the
// samples, the accepted steps and the NCC at its start and end (on that level's smoothing).
struct AlignmentLevel {
  double sigma = 0.0;
  int stride = 1;
  int64_t samples = 0;
  int iterations = 0;
  double ncc_start = 0.0, ncc_end = 0.0;
};

template <int D>
struct ImageAlignmentResult {
  AffineMap<D> transform;  // fixed world -> moving world: R(x) ~ a S(T x) + b
  double ncc_before = 0.0, ncc_after = 0.0;  // at the finest level's smoothing, the start's and the result's
  double overlap = 0.0;    // share of the region's samples that T maps inside the moving image
  int iterations = 0;      // accepted steps over all levels
  std::vector<AlignmentLevel> levels;
  std::string warning;     // "" or why the start was kept (no overlap, no improvement, a scale out of bounds)
};

// Aligns `fixed` (sampled at its voxel centres within `region`, world mm, widened by
// options.margin) onto `moving` starting from `initial` (fixed world -> moving world). Never
// returns a map with a lower NCC^2 than `initial`'s (it then keeps `initial` and says why in
// `warning`); a region outside either image gives `initial` and a warning. Throws
// std::invalid_argument for options that fail check() or an empty image.
template <int D>
ImageAlignmentResult<D> align_images(const Image<D>& fixed, const Image<D>& moving, const WorldBox<D>& region,
                                     const AffineMap<D>& initial, const ImageAlignmentOptions& options = {});

// The whole of `fixed` aligned onto the whole of `moving`, for a scan that lies anywhere in its
// own world frame (a scanner's, tens of mm and degrees from an atlas's). Both images are first
// block-averaged to voxels of half the finest level's sigma (and to at most about 2 million
// voxels), so that a whole-image level costs about what a structure's region does at full
// resolution; on them, `initial` is moved so that the two images' foreground centroids coincide
// (the voxels brighter than each image's mean: a head or a body against its background, in any
// units), then align_images runs over the fixed image's whole box (options.margin is not used).
template <int D>
struct WholeImageAlignment {
  ImageAlignmentResult<D> fit;                 // fixed world -> moving world
  Point<D> centroid_shift = Point<D>::Zero();  // moving's centroid minus initial(fixed's centroid)
  bool centred = false;                        // false: an image has no voxel above its mean (fit = initial)
};
template <int D>
WholeImageAlignment<D> align_whole_images(const Image<D>& fixed, const Image<D>& moving, const AffineMap<D>& initial,
                                          const ImageAlignmentOptions& options = {});

}  // namespace dsnake
