// Edge polarity and the shared sampling helpers; see polarity.h.
#include "energies/polarity.h"

#include "framework/core/errors.h"
#include "framework/core/image_filters.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>

namespace dsnake {

int polarity_sign(EdgePolarity polarity) {
  DSNAKE_ASSERT(polarity != EdgePolarity::kAuto, "the polarity is learned before it is used");
  return polarity == EdgePolarity::kBrightInside ? -1 : +1;
}

// Inside band minus outside band, summed vertex by vertex in order (the same for any threads).
template <int D>
EdgePolarity learn_polarity(const Image<D>& smoothed, const Snake<D>& snake, double band, double h) {
  const PointList<D> normals = snake.vertex_normals();
  const PointList<D>& q = snake.positions();
  const int steps = std::max(1, static_cast<int>(std::floor(band / h)));
  double inside = 0.0, outside = 0.0;
  for (int v = 0; v < snake.num_vertices(); ++v) {
    for (int k = 1; k <= steps; ++k) {
      inside += smoothed.sample(q[v] - (k * h) * normals[v]);
      outside += smoothed.sample(q[v] + (k * h) * normals[v]);
    }
  }
  return inside >= outside ? EdgePolarity::kBrightInside : EdgePolarity::kDarkInside;
}

template <int D>
const Image<D>& SmoothedImage<D>::of(const Image<D>& image, double sigma, SmoothedImageCache<D>* cache) {
  if (source_ == &image && sigma_ == sigma && grid_.same_geometry(image.grid()) && smoothed_)
    return *smoothed_;
  smoothed_ = cache ? cache->get(image, sigma)
                    : std::make_shared<const Image<D>>(sigma > 0 ? gaussian_blur(image, sigma) : image);
  source_ = &image;
  grid_ = image.grid();
  sigma_ = sigma;
  return *smoothed_;
}

template <int D>
double directional_derivative(const Image<D>& image, const Point<D>& x, const Point<D>& u, double h) {
  return (image.sample(x + h * u) - image.sample(x - h * u)) / (2 * h);
}

template <int D>
double half_smallest_spacing(const Grid<D>& grid) {
  return 0.5 * grid.spacing.minCoeff();
}

// The median of the voxels' gradient magnitudes by selection in two passes, without a copy of
// the volume (issue 21: 8 B per voxel and an nth_element over all of them on a CT): pass 1
// counts the magnitudes per bucket of the top bits of their IEEE-754 pattern (monotone for
// non-negative doubles) and finds the bucket holding the median's rank; pass 2 gathers that
// bucket's values and selects within them. The same value as an nth_element over all voxels,
// for any thread count (integer counts; the selected value does not depend on the order).
constexpr int kNoiseBucketShift = 46;  // 18 bits: sign, exponent and 6 mantissa bits
constexpr int64_t kNoiseBuckets = int64_t(1) << (64 - kNoiseBucketShift);

template <int D>
double gradient_noise_level(const Image<D>& image) {
  if (image.empty()) return 0.0;
  const std::vector<float>& u = image.data();  // differenced in double, without a copy
  const Grid<D>& grid = image.grid();
  const int64_t n = static_cast<int64_t>(u.size());
  auto magnitude = [&](int64_t l) {
    double s = 0.0;
    for (int a = 0; a < D; ++a) {
      const double d = partial_derivative(grid, u, l, a);
      s += d * d;
    }
    return std::sqrt(s);
  };
  auto bucket = [](double m) { return static_cast<int64_t>(std::bit_cast<uint64_t>(m) >> kNoiseBucketShift); };
  std::vector<int64_t> count(kNoiseBuckets, 0);
  double largest = 0.0;
#pragma omp parallel if (n >= 65536)
  {
    std::vector<int64_t> mine(kNoiseBuckets, 0);
    double top = 0.0;
#pragma omp for schedule(static) nowait
    for (int64_t l = 0; l < n; ++l) {
      const double m = magnitude(l);
      top = std::max(top, m);
      ++mine[bucket(m)];
    }
#pragma omp critical(dsnake_noise_level)
    {
      for (int64_t b = 0; b < kNoiseBuckets; ++b) count[b] += mine[b];
      largest = std::max(largest, top);
    }
  }
  const int64_t rank = n / 2;  // the element nth_element(begin, begin + n / 2, end) places
  int64_t below = 0, chosen = 0;
  for (; chosen < kNoiseBuckets; ++chosen) {
    if (below + count[chosen] > rank) break;
    below += count[chosen];
  }
  std::vector<double> in_bucket;
  in_bucket.reserve(count[chosen]);
#pragma omp parallel if (n >= 65536)
  {
    std::vector<double> mine;
#pragma omp for schedule(static) nowait
    for (int64_t l = 0; l < n; ++l) {
      const double m = magnitude(l);
      if (bucket(m) == chosen) mine.push_back(m);
    }
#pragma omp critical(dsnake_noise_level)
    in_bucket.insert(in_bucket.end(), mine.begin(), mine.end());
  }
  auto mid = in_bucket.begin() + (rank - below);
  std::nth_element(in_bucket.begin(), mid, in_bucket.end());
  return std::max(*mid, 0.01 * largest);
}

// Walks the ray until the first edge (a local maximum of |dI/du| above the floor), then reads
// its polarity along the vertex normal.
template <int D>
double polarity_factor(const Image<D>& smoothed, const PolarityProbe& probe, const Point<D>& q, const Point<D>& n,
                       const Point<D>& f) {
  const double length = f.norm();
  if (!(length > 0)) return 1.0;
  const Point<D> u = f / length;
  const double h = probe.step;
  const int steps = static_cast<int>(std::floor(probe.range / h));
  double here = std::abs(directional_derivative(smoothed, q, u, h));
  for (int j = 0; j <= steps; ++j) {
    const Point<D> x = q + (j * h) * u;
    const double next = j < steps ? std::abs(directional_derivative(smoothed, Point<D>(x + h * u), u, h)) : 0.0;
    if (here > probe.floor && here >= next) {
      const double across = directional_derivative(smoothed, x, n, h);
      return across * probe.sign < 0 ? -1.0 : 1.0;
    }
    here = next;
  }
  return 1.0;
}

template EdgePolarity learn_polarity<2>(const Image<2>&, const Snake<2>&, double, double);
template EdgePolarity learn_polarity<3>(const Image<3>&, const Snake<3>&, double, double);
template class SmoothedImage<2>;
template class SmoothedImage<3>;
template double directional_derivative<2>(const Image<2>&, const Point<2>&, const Point<2>&, double);
template double directional_derivative<3>(const Image<3>&, const Point<3>&, const Point<3>&, double);
template double half_smallest_spacing<2>(const Grid<2>&);
template double half_smallest_spacing<3>(const Grid<3>&);
template double gradient_noise_level<2>(const Image<2>&);
template double gradient_noise_level<3>(const Image<3>&);
template double polarity_factor<2>(const Image<2>&, const PolarityProbe&, const Point<2>&, const Point<2>&,
                                   const Point<2>&);
template double polarity_factor<3>(const Image<3>&, const PolarityProbe&, const Point<3>&, const Point<3>&,
                                   const Point<3>&);

}  // namespace dsnake
