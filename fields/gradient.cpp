// Gradient (edge-map) field; see gradient.h. Levi & Gotsman, D-Snake, §1: E_ext = -|grad I|^2.
#include "fields/gradient.h"

#include "framework/core/errors.h"
#include "fields/edge_map.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace dsnake {

template <int D>
GradientField<D>::GradientField(const GradientFieldOptions& options) : options_(checked(options, kType)) {}

// The edge map f = |grad (G_sigma * I)|^2 (§1: E_ext = -f) and its gradient, the force
// F = grad f = -grad P, kept on the image grid for linear sampling.
template <int D>
void GradientField<D>::compute(const Image<D>& image) {
  DSNAKE_ASSERT(image.num_voxels() > 0, "a non-empty image");
  const EdgeMap<D> edges = compute_edge_map(image, EdgeMapOptions{options_.sigma, options_.normalize}, false, type());
  edge_max_ = edges.f_max;
  edge_map_ = Image<D>(image.grid());
  vectors_ = VectorField<D>(image.grid());
  const int64_t n = image.num_voxels();
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    edge_map_[l] = edges.f[l];
    for (int a = 0; a < D; ++a) vectors_.at(l)[a] = edges.grad_f[a][l];
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
