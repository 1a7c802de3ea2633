#include "docs/examples/umbrella_energy.h"

namespace dsnake {

template <int D>
void UmbrellaEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  const auto& q = snake.positions();
  for (int v = 0; v < snake.num_vertices(); ++v) {
    const auto ring = snake.connectivity().neighbors(v);
    Point<D> mean = Point<D>::Zero();
    for (int u : ring) mean += q[u];
    mean /= static_cast<double>(ring.size());
    out[v] = q[v] + options_.lambda * (mean - q[v]);
  }
}

template <int D>
double UmbrellaEnergy<D>::value(const Snake<D>& snake) const {
  double e = 0;
  for (const auto& [i, j] : snake.connectivity().edges())
    e += 0.5 * (snake.positions()[i] - snake.positions()[j]).squaredNorm();
  return e;
}

template class UmbrellaEnergy<2>;
template class UmbrellaEnergy<3>;

}  // namespace dsnake
