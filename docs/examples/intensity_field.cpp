#include "docs/examples/intensity_field.h"

#include <algorithm>

namespace dsnake {

template <int D>
void IntensityField<D>::compute(const Image<D>& image) {
  const Grid<D>& g = image.grid();
  vectors_ = VectorField<D>(g);
  double largest = 0;
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    const GridIndex<D> idx = g.index(l);
    Point<D> grad;
    for (int a = 0; a < D; ++a) {  // central differences, one-sided at the border
      GridIndex<D> lo = idx, hi = idx;
      lo[a] = std::max(0, idx[a] - 1);
      hi[a] = std::min(g.size[a] - 1, idx[a] + 1);
      const int steps = hi[a] - lo[a];
      grad[a] = steps == 0 ? 0.0 : (image.at(hi) - image.at(lo)) / (steps * g.spacing[a]);
    }
    vectors_[l] = grad;
    largest = std::max(largest, grad.norm());
  }
  const double scale = largest > 0 ? (options_.toward == IntensityDirection::kBright ? 1.0 : -1.0) / largest : 0.0;
  for (auto& v : vectors_.data()) v *= scale;
}

template class IntensityField<2>;
template class IntensityField<3>;

}  // namespace dsnake
