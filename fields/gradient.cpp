// Gradient (edge-map) field; see gradient.h. Levi & Gotsman, D-Snake, §1: E_ext = -|grad I|^2.
#include "fields/gradient.h"

#include "framework/errors.h"
#include "framework/image_filters.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace dsnake {

template <int D>
GradientField<D>::GradientField(const GradientFieldOptions& options) : options_(options) {
  DSNAKE_ASSERT(options.sigma >= 0, "gradient field options: sigma >= 0");
}

template <int D>
void GradientField<D>::compute(const Image<D>& image) {
  const Grid<D>& grid = image.grid();
  const int64_t n = grid.num_voxels();
  DSNAKE_ASSERT(n > 0, "a non-empty image");
  std::vector<double> u(image.data().begin(), image.data().end()), scratch(n);

  // G_sigma * I, separable; per-axis deviation sigma / spacing voxels.
  gaussian_blur(grid, u, options_.sigma);

  // Edge map f = |grad (G_sigma * I)|^2 (§1: E_ext = -f).
  std::vector<double>& f = scratch;
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    double sum = 0.0;
    for (int a = 0; a < D; ++a) {
      const double g = partial_derivative(grid, u, l, a);
      sum += g * g;
    }
    f[l] = sum;
  }
  double f_max = 0.0;  // a max is exact, so the reduction order does not matter
#pragma omp parallel for reduction(max : f_max) schedule(static)
  for (int64_t l = 0; l < n; ++l) f_max = std::max(f_max, f[l]);
  if (options_.normalize) {
    const double scale = f_max > 0 ? 1.0 / f_max : 0.0;
#pragma omp parallel for schedule(static)
    for (int64_t l = 0; l < n; ++l) f[l] *= scale;
    f_max = f_max > 0 ? 1.0 : 0.0;
  }
  edge_max_ = f_max;

  // Force F = grad f = -grad P.
  edge_map_ = Image<D>(grid);
  vectors_ = VectorField<D>(grid);
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    Point<D> g;
    for (int a = 0; a < D; ++a) g[a] = partial_derivative(grid, f, l, a);
    vectors_[l] = g;
    edge_map_[l] = static_cast<float>(f[l]);
  }
}

template <int D>
Point<D> GradientField<D>::force(const Point<D>& x, const Point<D>&) const {
  DSNAKE_ASSERT(!vectors_.empty(), "compute() before force()");
  return vectors_.sample(x);
}

template <int D>
double GradientField<D>::potential(const Point<D>& x) const {
  DSNAKE_ASSERT(!edge_map_.empty(), "compute() before potential()");
  return std::max(0.0, edge_max_ - edge_map_.sample(x));  // f is stored as float
}

template class GradientField<2>;
template class GradientField<3>;

}  // namespace dsnake
