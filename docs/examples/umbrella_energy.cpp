#include "docs/examples/umbrella_energy.h"

#include "framework/operators/mesh_operators.h"

namespace dsnake {

template <int D>
void UmbrellaEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  const auto& q = snake.positions();
  for (int v = 0; v < snake.num_vertices(); ++v) {
    // q_v - lambda (L q)_v, with the framework's umbrella Laplacian
    out[v] = q[v] - options_.lambda * umbrella_laplacian<D>(snake.connectivity(), q, v);
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
