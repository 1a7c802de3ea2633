// Image filters shared by fields and phantoms, on float images or on double buffers laid out
// on a grid (x fastest). All are spacing-aware and give the same result for any thread count
// (each output voxel is a fixed-order sum of its inputs).
#pragma once

#include "framework/core/image.h"

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace dsnake {

// Separable Gaussian blur, in place, with standard deviation `sigma` in physical units (per
// axis sigma / spacing voxels), truncated at 3 sigma, border replicated. sigma <= 0: no-op.
template <int D>
void gaussian_blur(const Grid<D>& grid, std::vector<double>& values, double sigma);
template <int D>
Image<D> gaussian_blur(const Image<D>& image, double sigma);
// The same, reusing the image's own storage for the result (no second float volume).
template <int D>
Image<D> gaussian_blur(Image<D>&& image, double sigma);

// The mean of every block of f[a] voxels along each axis a (f[a] >= 1; a last, shorter block
// averages what it holds): a grid f times coarser whose voxel centres are the blocks' centres, in
// the same world frame. What a coarse level needs before a wide Gaussian, at 1 / prod(f) of the
// voxels.
template <int D>
Image<D> block_average(const Image<D>& image, const GridIndex<D>& f);

// d u / d x_axis at voxel l in physical units: central differences inside, one-sided at the
// border, 0 along an axis of a single voxel.
template <int D>
double partial_derivative(const Grid<D>& grid, const std::vector<double>& u, int64_t l, int axis);
// The same on float values (an image's own data, without a double copy), in double precision:
// the same bits as on the values widened to double.
template <int D>
double partial_derivative(const Grid<D>& grid, const std::vector<float>& u, int64_t l, int axis);

// partial_derivative for a caller that knows voxel l's index i along the axis, the axis's size
// and stride (voxels between neighbours) and its spacing h, as a loop over rows does: the same
// arithmetic, so the same bits, without dividing l to find i.
template <class T>
inline double partial_derivative_at(const T* u, int64_t l, int64_t stride, int i, int size, double h) {
  if (size < 2) return 0.0;
  if (i == 0) return (double(u[l + stride]) - double(u[l])) / h;
  if (i == size - 1) return (double(u[l]) - double(u[l - stride])) / h;
  return (double(u[l + stride]) - double(u[l - stride])) / (2.0 * h);
}

// A grid's rows along x (x fastest), for loops that take each voxel's index along every axis
// from its row rather than by dividing its linear index (partial_derivative_at).
template <int D>
struct GridRows {
  explicit GridRows(const Grid<D>& grid) {
    int64_t s = 1;
    for (int a = 0; a < D; ++a) size[a] = grid.size[a], stride[a] = s, s *= grid.size[a];
    rows = size[0] > 0 ? s / size[0] : 0;
  }
  // The index of the first voxel of row `row` (x = 0); its voxels are row * size[0] + x.
  GridIndex<D> row_index(int64_t row) const {
    GridIndex<D> i;
    i[0] = 0;
    for (int a = 1; a < D; ++a) i[a] = static_cast<int>(row % size[a]), row /= size[a];
    return i;
  }
  std::array<int, D> size;
  std::array<int64_t, D> stride;
  int64_t rows = 0;
};

// The gradient of an image, by partial_derivative on every axis.
template <int D>
VectorField<D> gradient(const Image<D>& image);

// Gaussian-smoothed copies of images, shared by the energies of one run (EnergyContext): each
// (image, sigma) is smoothed once however many energies sample it (the recipes' two profile
// terms and the external polarity rule all smooth by 1 mm). Keyed by the image's
// address: valid only while the images it was given live and are not modified, as within a run.
template <int D>
class SmoothedImageCache {
 public:
  // The image smoothed by sigma (sigma <= 0: a copy), computed on the first request.
  std::shared_ptr<const Image<D>> get(const Image<D>& image, double sigma);

 private:
  struct Entry {
    const Image<D>* source;
    double sigma;
    std::shared_ptr<const Image<D>> smoothed;
  };
  std::mutex mutex_;
  std::vector<Entry> entries_;
};

}  // namespace dsnake
