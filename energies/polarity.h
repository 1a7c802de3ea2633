// Which side of an edge is inside: the polarity of an edge seen from a closed template, and the
// image helpers the polarity-aware forces share (the external energy's polarity rule and the
// profile force, energies/external.h and energies/profile.h).
//
// An edge is "bright_inside" where the intensity falls when one crosses it outwards (along the
// template's outward normal n: dI/dn < 0), "dark_inside" where it rises (dI/dn > 0). "auto" is
// learned once from the start: learn_polarity() compares the mean intensity just inside the start
// contour/mesh with the mean just outside (a band of the given width along the vertex normals).
#pragma once

#include "framework/core/image.h"
#include "framework/core/image_filters.h"
#include "framework/core/options.h"
#include "framework/core/shape.h"

namespace dsnake {

// The side an edge's bright part is on, or "auto" (learned from the start).
enum class EdgePolarity { kBrightInside, kDarkInside, kAuto };
template <>
struct EnumNames<EdgePolarity> {
  static constexpr std::array<std::pair<EdgePolarity, const char*>, 3> table{
      {{EdgePolarity::kBrightInside, "bright_inside"}, {EdgePolarity::kDarkInside, "dark_inside"}, {EdgePolarity::kAuto, "auto"}}};
};

// The sign s of dI/dn that an edge of the polarity has: -1 for bright_inside, +1 for dark_inside
// (a programmer error for auto: learn it first).
int polarity_sign(EdgePolarity polarity);

// Learns the polarity from the snake as it stands (the start): the mean of the smoothed image
// over offsets t in [-band, -h] along every vertex normal (inside) against the mean over
// [h, band] (outside), h the sampling step in mm. Bright inside when the inside mean is larger
// (ties: bright_inside). Deterministic (serial sums).
template <int D>
EdgePolarity learn_polarity(const Image<D>& smoothed, const Snake<D>& snake, double band, double h);

// A Gaussian-smoothed copy of an image (sigma in mm), recomputed only when the image or sigma
// changes: energies keep one per image they sample, so that binding again after a remesh costs
// nothing. With a cache (EnergyContext::smoothed_images) the copy is shared with the run's other
// energies that smooth the same image by the same sigma.
template <int D>
class SmoothedImage {
 public:
  // The image smoothed by sigma (sigma <= 0: a copy).
  const Image<D>& of(const Image<D>& image, double sigma, SmoothedImageCache<D>* cache = nullptr);
  const Image<D>& image() const { return smoothed_ ? *smoothed_ : empty_; }

 private:
  const Image<D>* source_ = nullptr;
  Grid<D> grid_;
  double sigma_ = -1.0;
  std::shared_ptr<const Image<D>> smoothed_;
  Image<D> empty_;
};

// The derivative of the image along the unit direction u at x, by central differences of linear
// samples at x +- h u (h in mm); physical units per mm.
template <int D>
double directional_derivative(const Image<D>& image, const Point<D>& x, const Point<D>& u, double h);

// Half the smallest voxel size of the grid: the default sampling step along normals (mm).
template <int D>
double half_smallest_spacing(const Grid<D>& grid);

// A noise level of the smoothed image, against which an edge counts as one: the median over the
// voxels of |grad I| (central differences, physical units), but at least 1% of the largest (so
// that the rounding ripples of a noiseless image, whose median is 0, do not count as edges).
// Padding (voxels of value exactly 0 with a gradient of exactly 0: the background of a
// skull-stripped or masked scan) is left out of the median, so that a scan that is mostly
// padding still has its tissue's noise level; 0 for an image that is nothing but padding.
template <int D>
double gradient_noise_level(const Image<D>& image);

// At most this many magnitudes are held at once by gradient_noise_level (32 MB).
constexpr int64_t kNoiseGatherMax = int64_t(1) << 22;

namespace detail {
// gradient_noise_level holding at most gather_max magnitudes at once (exposed for tests, which
// force the passes that a large image takes on a small one).
template <int D>
double gradient_noise_level(const Image<D>& image, int64_t gather_max);
}  // namespace detail

// The polarity rule's search along a force (energies/external.h): the ray's step h and length in
// mm, the derivative an edge must exceed (intensity per mm) and the sign of dI/dn a right edge has.
struct PolarityProbe {
  double step = 1.0, range = 5.0, floor = 0.0;
  int sign = -1;
};

// +1, or -1 where the force f at q (outward unit normal n) pulls q onto an edge of the wrong
// polarity: the first local maximum of |dI/du| above probe.floor along q + t u, u = f / |f|,
// t = 0, h, ..., <= range, whose dI/dn has the sign opposite to probe.sign. +1 for f = 0 and
// when no edge is found.
template <int D>
double polarity_factor(const Image<D>& smoothed, const PolarityProbe& probe, const Point<D>& q, const Point<D>& n,
                       const Point<D>& f);

}  // namespace dsnake
