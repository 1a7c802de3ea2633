// Balloon force; see balloon.h. Cohen 1991, eq. (5) there: F = k1 n(s).
#include "energies/balloon.h"

#include "framework/core/errors.h"

namespace dsnake {

template <int D>
void BalloonEnergy<D>::bind(const EnergyContext<D>&, const Snake<D>& snake) {
  normals_.reserve(snake.num_vertices());
}

template <int D>
void BalloonEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  DSNAKE_ASSERT(int(out.size()) == snake.num_vertices(), "out has one entry per vertex");
  snake.vertex_normals(normals_);
  const PointList<D>& q = snake.positions();
  for (int v = 0; v < snake.num_vertices(); ++v) out[v] = q[v] + options_.pressure * normals_[v];
}

template <int D>
double BalloonEnergy<D>::value(const Snake<D>& snake) const {
  return -options_.pressure * snake.signed_measure();
}

template class BalloonEnergy<2>;
template class BalloonEnergy<3>;

}  // namespace dsnake
