#include "framework/core/errors.h"
#include "framework/core/image_filters.h"

#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {

// Distance in the linear index between neighbours along `axis` (x fastest).
template <int D>
int64_t axis_stride(const Grid<D>& grid, int axis) {
  int64_t s = 1;
  for (int a = 0; a < axis; ++a) s *= grid.size[a];
  return s;
}

// One pass of the separable Gaussian along `axis` (deviation sigma_voxels, 3-sigma support,
// weights summing to 1, border replicated), in place. The support is ceil(3 sigma_voxels) less a
// 1e-9 margin: a spacing a rounding error off a round value (1 - 2e-16 mm from a NRRD space
// direction's norm, with sigma 1 mm) must not add a tap of relative weight e^-8 and change the
// field by 1e-4. In place: each thread copies the part of a line it is about to
// overwrite (one padded x-row, or a block of columns across the axis) instead of the pass
// writing a second volume, which would cost a whole volume's first touch per blur.
template <int D>
void blur_axis(const Grid<D>& grid, int axis, double sigma_voxels, std::vector<double>& u) {
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma_voxels - 1e-9)));
  std::vector<double> weight(radius + 1);
  double total = 0.0;
  for (int k = 0; k <= radius; ++k) {
    weight[k] = std::exp(-0.5 * k * k / (sigma_voxels * sigma_voxels));
    total += k == 0 ? weight[k] : 2.0 * weight[k];
  }
  for (double& w : weight) w /= total;
  const int64_t stride = axis_stride(grid, axis);
  const int size = grid.size[axis];
  const int64_t lines = grid.num_voxels() / (stride * size);
  // Every voxel's sum is w0 u[i] + w1 (u[i-1] + u[i+1]) + w2 (...) + ..., in that order, in
  // both branches (the same bits whatever the axis layout, block width or thread count). Along
  // x, one padded row at a time; along y or z, blocks of up to kColumns contiguous x-columns
  // across the axis (vectorised).
  if (stride == 1) {
#pragma omp parallel
    {
      std::vector<double> padded(size + 2 * radius);
#pragma omp for schedule(static)
      for (int64_t line = 0; line < lines; ++line) {
        double* row = u.data() + line * size;
        for (int j = 0; j < size + 2 * radius; ++j) padded[j] = row[std::clamp(j - radius, 0, size - 1)];
        const double* c = padded.data() + radius;
        for (int i = 0; i < size; ++i) {
          double sum = weight[0] * c[i];
          for (int k = 1; k <= radius; ++k) sum += weight[k] * (c[i - k] + c[i + k]);
          row[i] = sum;
        }
      }
    }
    return;
  }
  constexpr int64_t kColumns = 128;  // a block of 300 rows is 300 kB: it stays in L2
  const int64_t blocks_per_line = (stride + kColumns - 1) / kColumns;
#pragma omp parallel
  {
    std::vector<double> block(size_t(size) * kColumns);
#pragma omp for schedule(static)
    for (int64_t task = 0; task < lines * blocks_per_line; ++task) {
      const int64_t line = task / blocks_per_line, x0 = task % blocks_per_line * kColumns;
      const int64_t width = std::min(kColumns, stride - x0);
      double* at = u.data() + line * size * stride + x0;
      for (int i = 0; i < size; ++i) std::copy_n(at + i * stride, width, block.data() + i * width);
      for (int i = 0; i < size; ++i) {
        double* dst = at + i * stride;
        const double* src = block.data() + i * width;
        for (int64_t x = 0; x < width; ++x) dst[x] = weight[0] * src[x];
        for (int k = 1; k <= radius; ++k) {
          const double* lo = block.data() + std::max(i - k, 0) * width;
          const double* hi = block.data() + std::min(i + k, size - 1) * width;
          const double w = weight[k];
          for (int64_t x = 0; x < width; ++x) dst[x] += w * (lo[x] + hi[x]);
        }
      }
    }
  }
}

// The central (one-sided at the border) difference, in double precision whatever the values'
// type: floats are widened exactly, so a float image gives the bits of its double copy.
template <int D, class T>
double partial_derivative_of(const Grid<D>& grid, const std::vector<T>& u, int64_t l, int axis) {
  const int size = grid.size[axis];
  const int64_t stride = axis_stride(grid, axis);
  return partial_derivative_at(u.data(), l, stride, static_cast<int>((l / stride) % size), size, grid.spacing[axis]);
}

}  // namespace

template <int D>
void gaussian_blur(const Grid<D>& grid, std::vector<double>& values, double sigma) {
  if (!(sigma > 0)) return;
  for (int a = 0; a < D; ++a) {
    const double s = sigma / grid.spacing[a];
    if (grid.size[a] < 2 || s < 1e-3) continue;
    blur_axis(grid, a, s, values);
  }
}

template <int D>
Image<D> gaussian_blur(const Image<D>& image, double sigma) {
  return gaussian_blur(Image<D>(image), sigma);
}

template <int D>
Image<D> gaussian_blur(Image<D>&& image, double sigma) {
  std::vector<double> u(image.data().begin(), image.data().end());
  gaussian_blur(image.grid(), u, sigma);
  Image<D> out(std::move(image));
  for (size_t l = 0; l < u.size(); ++l) out[l] = static_cast<float>(u[l]);
  return out;
}

template <int D>
double partial_derivative(const Grid<D>& grid, const std::vector<double>& u, int64_t l, int axis) {
  return partial_derivative_of<D>(grid, u, l, axis);
}

template <int D>
double partial_derivative(const Grid<D>& grid, const std::vector<float>& u, int64_t l, int axis) {
  return partial_derivative_of<D>(grid, u, l, axis);
}

template <int D>
VectorField<D> gradient(const Image<D>& image) {
  const auto& g = image.grid();
  const std::vector<float>& u = image.data();
  VectorField<D> out(g);
  const int64_t n = g.num_voxels();
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l)
    for (int a = 0; a < D; ++a) out[l][a] = partial_derivative(g, u, l, a);
  return out;
}

template <int D>
std::shared_ptr<const Image<D>> SmoothedImageCache<D>::get(const Image<D>& image, double sigma) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const Entry& e : entries_)
    if (e.source == &image && e.sigma == sigma && e.smoothed->grid().same_geometry(image.grid())) return e.smoothed;
  auto smoothed = std::make_shared<const Image<D>>(sigma > 0 ? gaussian_blur(image, sigma) : image);
  entries_.push_back({&image, sigma, smoothed});
  return smoothed;
}

template <int D>
Image<D> block_average(const Image<D>& image, const GridIndex<D>& f) {
  const Grid<D>& g = image.grid();
  Grid<D> c = g;
  Point<D> shift = Point<D>::Zero();
  for (int a = 0; a < D; ++a) {
    DSNAKE_ASSERT(f[a] >= 1, "block sizes are positive");
    c.size[a] = (g.size[a] + f[a] - 1) / f[a];
    c.spacing[a] = g.spacing[a] * double(f[a]);
    shift[a] = 0.5 * double(std::min<int64_t>(f[a], g.size[a]) - 1) * g.spacing[a];
  }
  c.origin = g.origin + g.direction * shift;  // voxel 0 at the first block's centre
  std::vector<double> sum(size_t(c.num_voxels()), 0.0), count(size_t(c.num_voxels()), 0.0);
  // voxel l's index kept as an odometer (x fastest), and its block's linear index with it
  GridIndex<D> idx = GridIndex<D>::Zero();
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    int64_t k = 0;
    for (int a = D - 1; a >= 0; --a) k = k * c.size[a] + idx[a] / f[a];
    sum[size_t(k)] += image[l], count[size_t(k)] += 1.0;
    for (int a = 0; a < D && ++idx[a] == g.size[a]; ++a) idx[a] = 0;
  }
  Image<D> out(c);
  for (int64_t k = 0; k < out.num_voxels(); ++k) out[k] = float(sum[size_t(k)] / count[size_t(k)]);
  return out;
}

template class SmoothedImageCache<2>;
template class SmoothedImageCache<3>;
template void gaussian_blur<2>(const Grid<2>&, std::vector<double>&, double);
template void gaussian_blur<3>(const Grid<3>&, std::vector<double>&, double);
template Image<2> gaussian_blur<2>(const Image<2>&, double);
template Image<3> gaussian_blur<3>(const Image<3>&, double);
template Image<2> block_average<2>(const Image<2>&, const GridIndex<2>&);
template Image<3> block_average<3>(const Image<3>&, const GridIndex<3>&);
template Image<2> gaussian_blur<2>(Image<2>&&, double);
template Image<3> gaussian_blur<3>(Image<3>&&, double);
template double partial_derivative<2>(const Grid<2>&, const std::vector<double>&, int64_t, int);
template double partial_derivative<2>(const Grid<2>&, const std::vector<float>&, int64_t, int);
template double partial_derivative<3>(const Grid<3>&, const std::vector<float>&, int64_t, int);
template double partial_derivative<3>(const Grid<3>&, const std::vector<double>&, int64_t, int);
template VectorField<2> gradient<2>(const Image<2>&);
template VectorField<3> gradient<3>(const Image<3>&);

}  // namespace dsnake
