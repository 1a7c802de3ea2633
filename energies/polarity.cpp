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

// The voxels' gradient magnitudes |grad I| (partial_derivative's central differences, in double
// precision), visited row by row (x fastest) as visit(magnitude) over the rows of this thread's
// share of an enclosing parallel region: partial_derivative_at's arithmetic, so the same bits,
// without dividing each voxel's linear index. Padding is not visited: a voxel whose value is
// exactly 0 and whose gradient is exactly 0 (the background a skull strip, a mask or a
// resampling outside the scan's field of view left), which says nothing about the scan's noise
// and, when it is most of the volume, would make the median 0.
template <int D, class Visit>
void for_each_gradient_magnitude(const Image<D>& image, Visit&& visit) {
  const Grid<D>& grid = image.grid();
  const float* u = image.data().data();
  const GridRows<D> rows(grid);
  const int nx = rows.size[0];
#pragma omp for schedule(static) nowait
  for (int64_t row = 0; row < rows.rows; ++row) {
    GridIndex<D> i = rows.row_index(row);
    for (i[0] = 0; i[0] < nx; ++i[0]) {
      const int64_t l = row * nx + i[0];
      double sum = 0.0;
      for (int a = 0; a < D; ++a) {
        const double d = partial_derivative_at(u, l, rows.stride[a], i[a], rows.size[a], grid.spacing[a]);
        sum += d * d;
      }
      if (sum == 0.0 && u[l] == 0.0f) continue;
      visit(std::sqrt(sum));
    }
  }
}

// The median of the voxels' gradient magnitudes by radix selection on their IEEE-754 patterns
// (monotone for non-negative doubles), without a copy of the volume: each pass counts,
// among the voxels whose pattern begins with the bits found so far, the next 16 bits, and keeps
// the digit that holds the median's rank; once the voxels that share the found bits are at most
// `gather_max`, they are gathered and selected (nth_element). So a noisy image takes two passes
// over the volume, and one whose magnitudes are mostly equal (a phantom, a label map: most of
// them 0) at most four, never holding more than gather_max values (the whole first bucket
// can be most of a phantom's voxels). The same value as an nth_element over all voxels, for any
// thread count (integer counts; the selected value does not depend on the order).
constexpr int kNoiseDigitBits = 16;
constexpr int64_t kNoiseDigits = int64_t(1) << kNoiseDigitBits;

namespace detail {

template <int D>
double gradient_noise_level(const Image<D>& image, int64_t gather_max) {
  if (image.empty()) return 0.0;
  const int64_t n = image.num_voxels();
  auto key = [](double m) { return std::bit_cast<uint64_t>(m); };
  uint64_t prefix = 0;  // the selected pattern's first `known` bits
  int known = 0;
  int64_t rank = 0;        // the element nth_element(begin, begin + m / 2, end) places (m: the
                           // voxels that are not padding, counted by the first pass), among...
  int64_t candidates = n;  // ...the voxels whose pattern begins with prefix
  double largest = 0.0;
  std::vector<int64_t> count(kNoiseDigits);
  while (known < 64 && (known == 0 || candidates > gather_max)) {
    const int shift = 64 - known - kNoiseDigitBits;
    std::fill(count.begin(), count.end(), 0);
#pragma omp parallel if (n >= 65536)
    {
      std::vector<int64_t> mine(kNoiseDigits, 0);
      double top = 0.0;
      for_each_gradient_magnitude(image, [&](double m) {
        const uint64_t k = key(m);
        top = std::max(top, m);
        if (known == 0 || (k >> (64 - known)) == prefix) ++mine[(k >> shift) & (kNoiseDigits - 1)];
      });
#pragma omp critical(dsnake_noise_level)
      {
        for (int64_t d = 0; d < kNoiseDigits; ++d) count[d] += mine[d];
        largest = std::max(largest, top);
      }
    }
    if (known == 0) {
      int64_t visited = 0;
      for (int64_t d = 0; d < kNoiseDigits; ++d) visited += count[d];
      if (visited == 0) return 0.0;  // nothing but padding
      rank = visited / 2;
    }
    int64_t digit = 0;
    for (; digit < kNoiseDigits - 1 && count[digit] <= rank; ++digit) rank -= count[digit];
    prefix = (prefix << kNoiseDigitBits) | uint64_t(digit);
    known += kNoiseDigitBits;
    candidates = count[digit];
  }
  double median;
  if (known == 64) {
    median = std::bit_cast<double>(prefix);
  } else {
    std::vector<double> gathered;
    gathered.reserve(candidates);
#pragma omp parallel if (n >= 65536)
    {
      std::vector<double> mine;
      for_each_gradient_magnitude(image, [&](double m) {
        if ((key(m) >> (64 - known)) == prefix) mine.push_back(m);
      });
#pragma omp critical(dsnake_noise_level)
      gathered.insert(gathered.end(), mine.begin(), mine.end());
    }
    auto mid = gathered.begin() + rank;
    std::nth_element(gathered.begin(), mid, gathered.end());
    median = *mid;
  }
  return std::max(median, 0.01 * largest);
}

template double gradient_noise_level<2>(const Image<2>&, int64_t);
template double gradient_noise_level<3>(const Image<3>&, int64_t);

}  // namespace detail

template <int D>
double gradient_noise_level(const Image<D>& image) {
  return detail::gradient_noise_level(image, kNoiseGatherMax);
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
