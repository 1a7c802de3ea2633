// Edge map f = |grad(G_sigma*I)|^2 and its gradient; see edge_map.h (D-Snake §2; Xu & Prince 1998).
#include "fields/edge_map.h"

#include "framework/core/errors.h"
#include "framework/core/image_filters.h"

#include <algorithm>
#include <cstdio>

namespace dsnake {

namespace {

// The edge map; `owned` (the image itself, or null) is released once u holds its copy.
template <int D>
EdgeMap<D> edge_map(const Image<D>& image, Image<D>* owned, const EdgeMapOptions& options, bool with_gradient_signs,
                    const std::string& field_type) {
  DSNAKE_ASSERT(options.sigma >= 0, "edge map: sigma >= 0");
  EdgeMap<D> out;
  out.grid = image.grid();
  const Grid<D>& grid = out.grid;
  const int64_t n = grid.num_voxels();
  DSNAKE_ASSERT(n > 0, "a non-empty image");
  // The image's own scale, for the no-edge test below (read while the image is here).
  double i_max = 0.0;
  for (float v : image.data()) i_max = std::max(i_max, double(std::abs(v)));
  // Double precision buffers, each allocated only while it is needed (the peak of a
  // field's computation is here): the smoothed image u, then f, then the float outputs.
  std::vector<double> u(image.data().begin(), image.data().end());
  if (owned) std::vector<float>().swap(owned->data());
  gaussian_blur(grid, u, options.sigma);
  std::vector<double> f(n);
  if (with_gradient_signs) out.gradient_signs.resize(n);
  const GridRows<D> axes(grid);
#pragma omp parallel for schedule(static)
  for (int64_t row = 0; row < axes.rows; ++row) {
    GridIndex<D> i = axes.row_index(row);
    for (i[0] = 0; i[0] < axes.size[0]; ++i[0]) {
      const int64_t l = row * axes.size[0] + i[0];
      double sum = 0.0;
      unsigned signs = 0;
      for (int a = 0; a < D; ++a) {
        const double g = partial_derivative_at(u.data(), l, axes.stride[a], i[a], axes.size[a], grid.spacing[a]);
        sum += g * g;
        const float rounded = static_cast<float>(g);  // the sign of the float the masks were made of
        signs |= (rounded > 0.f ? 1u : 0u) << (2 * a) | (rounded < 0.f ? 1u : 0u) << (2 * a + 1);
      }
      f[l] = sum;
      if (with_gradient_signs) out.gradient_signs[l] = static_cast<uint8_t>(signs);
    }
  }
  std::vector<double>().swap(u);
  double f_max = 0.0;  // max is exact: the reduction order does not matter
#pragma omp parallel for reduction(max : f_max) schedule(static)
  for (int64_t l = 0; l < n; ++l) f_max = std::max(f_max, f[l]);
  // Rounding noise of a constant image is not an edge (relative to the image's own scale).
  if (!(f_max > 1e-24 * std::max(1.0, i_max * i_max))) {
    std::fprintf(stderr, "warning: %s field: the image has no edges (constant after blurring); the field is zero\n",
                 field_type.c_str());
    out.f.assign(n, 0.0f);
    for (int a = 0; a < D; ++a) {
      out.grad_f[a].assign(n, 0.0f);
    }
    if (with_gradient_signs) out.gradient_signs.assign(n, 0);
    out.f_max = 0.0;
    return out;
  }
  if (options.normalize) {
    const double scale = 1.0 / f_max;
#pragma omp parallel for schedule(static)
    for (int64_t l = 0; l < n; ++l) f[l] *= scale;
    f_max = 1.0;
  }
  out.f_max = f_max;
  out.f.resize(n);
  for (int a = 0; a < D; ++a) out.grad_f[a].resize(n);
#pragma omp parallel for schedule(static)
  for (int64_t row = 0; row < axes.rows; ++row) {
    GridIndex<D> i = axes.row_index(row);
    for (i[0] = 0; i[0] < axes.size[0]; ++i[0]) {
      const int64_t l = row * axes.size[0] + i[0];
      out.f[l] = static_cast<float>(f[l]);
      for (int a = 0; a < D; ++a)
        out.grad_f[a][l] =
            static_cast<float>(partial_derivative_at(f.data(), l, axes.stride[a], i[a], axes.size[a], grid.spacing[a]));
    }
  }
  return out;
}

}  // namespace

template <int D>
EdgeMap<D> compute_edge_map(const Image<D>& image, const EdgeMapOptions& options, bool with_gradient_signs,
                            const std::string& field_type) {
  return edge_map(image, static_cast<Image<D>*>(nullptr), options, with_gradient_signs, field_type);
}

template <int D>
EdgeMap<D> compute_edge_map(Image<D>&& image, const EdgeMapOptions& options, bool with_gradient_signs,
                            const std::string& field_type) {
  return edge_map(image, &image, options, with_gradient_signs, field_type);
}

template EdgeMap<2> compute_edge_map(const Image<2>&, const EdgeMapOptions&, bool, const std::string&);
template EdgeMap<3> compute_edge_map(const Image<3>&, const EdgeMapOptions&, bool, const std::string&);
template EdgeMap<2> compute_edge_map(Image<2>&&, const EdgeMapOptions&, bool, const std::string&);
template EdgeMap<3> compute_edge_map(Image<3>&&, const EdgeMapOptions&, bool, const std::string&);

}  // namespace dsnake
