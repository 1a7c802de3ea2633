// The edge map shared by the diffused fields (GVF, DDGVF, VFC, distance): f = |grad(G_sigma*I)|^2,
// optionally normalised to [0, 1], its gradient grad f and (for DDGVF) the sign of each
// component of the gradient of the blurred image. Levi & Gotsman, D-Snake, §2; Xu & Prince 1998. Float arrays, one per
// component (structure of arrays), laid out on the image grid (x fastest), in physical units.
#pragma once

#include "framework/core/image.h"
#include "framework/core/options.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace dsnake {

struct EdgeMapOptions {
  double sigma = 1.0;     // Gaussian pre-smoothing, standard deviation in physical units
  bool normalize = true;  // scale f to [0, 1] by its maximum

  // JSON: "sigma", "normalize" (flattened into the field's object).
  template <class V>
  void visit(V& v) {
    v(sigma, Key{"sigma", "mm", "Gaussian pre-smoothing of the image before the edge map, standard deviation (0: none)",
                 Range::at_least(0)});
    v(normalize, Key{"normalize", "", "scale the edge map f = |grad(G_sigma * I)|^2 to [0, 1] by its maximum"});
  }
};

template <int D>
struct EdgeMap {
  Grid<D> grid;
  std::vector<float> f;                          // the edge map, one value per voxel
  std::array<std::vector<float>, D> grad_f;      // d f / d x_a, 1/mm
  // Only if asked for (DDGVF's masks): per voxel, bit 2a set where d (G_sigma*I) / d x_a > 0 and
  // bit 2a + 1 where it is < 0, both clear where it is 0, the derivative rounded to float
  // first (one byte per voxel instead of D floats).
  std::vector<uint8_t> gradient_signs;
  double f_max = 0.0;                            // max f after normalisation (0: no edges)
};

// Builds the edge map of `image`. A constant image (f = 0 everywhere) prints a warning naming
// `field_type` on stderr; the caller then returns a zero field. Thread-count independent.
template <int D>
EdgeMap<D> compute_edge_map(const Image<D>& image, const EdgeMapOptions& options, bool with_gradient_signs,
                            const std::string& field_type);
// The same, releasing the image's voxels once they are read (before the edge map's first
// whole-volume buffer beyond the blurred copy): for ExternalField::compute_releasing.
template <int D>
EdgeMap<D> compute_edge_map(Image<D>&& image, const EdgeMapOptions& options, bool with_gradient_signs,
                            const std::string& field_type);

}  // namespace dsnake
