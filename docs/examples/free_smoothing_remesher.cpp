#include "docs/examples/free_smoothing_remesher.h"

namespace dsnake {

template <int D>
RemeshReport FreeSmoothingRemesher<D>::apply(Snake<D>& snake, const RemeshContext<D>& context) {
  const PointList<D> q = snake.positions();  // a Jacobi sweep: every move from the old positions
  for (int v = 0; v < snake.num_vertices(); ++v) {
    if (snake.is_deformation_vertex(v)) continue;
    const auto ring = snake.connectivity().neighbors(v);
    Point<D> mean = Point<D>::Zero();
    for (int u : ring) mean += q[u];
    mean /= static_cast<double>(ring.size());
    snake.positions()[v] = q[v] + options_.lambda * (mean - q[v]);
  }
  return {kType, snake.num_vertices(), snake.num_vertices(), 0};
}

template class FreeSmoothingRemesher<2>;
template class FreeSmoothingRemesher<3>;

}  // namespace dsnake
