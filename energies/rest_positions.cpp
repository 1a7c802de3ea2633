// Rest positions of free vertices by a local similarity fit; see rest_positions.h.
#include "energies/rest_positions.h"

#include "energies/mls_weights.h"
#include "framework/core/errors.h"

#include <algorithm>

namespace dsnake {

template <int D>
RestPositions<D> rest_positions(const Template<D>& tmpl, const Snake<D>& snake, int count) {
  using Mat = Eigen::Matrix<double, D, D>;
  const int n = snake.num_vertices();
  const PointList<D>& q = snake.positions();
  const Connectivity& c = snake.connectivity();
  DSNAKE_ASSERT(count >= D, "a similarity needs at least D point pairs");
  RestPositions<D> out;
  out.positions.resize(n);
  out.rotation.assign(n, Mat::Identity());
  // A length scale for the weights' floor: the mean edge length (no division by zero at v).
  double mean_edge = 0.0;
  const auto edges = c.edges();
  for (const auto& e : edges) mean_edge += (q[e[0]] - q[e[1]]).norm();
  const double eps2 = edges.empty() ? 1.0 : std::max(1e-12, std::pow(0.1 * mean_edge / double(edges.size()), 2));

#pragma omp parallel if (n >= 256)
  {
    std::vector<int> queue, seen_list, found;
    std::vector<uint8_t> seen(n, 0);
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v) {
      // Breadth-first from v over edges until `count` deformation vertices (other than v) are found.
      queue.assign(1, v);
      seen_list.assign(1, v);
      seen[v] = 1;
      found.clear();
      for (size_t head = 0; head < queue.size() && int(found.size()) < count; ++head) {
        for (int w : c.neighbors(queue[head])) {
          if (seen[w]) continue;
          seen[w] = 1;
          seen_list.push_back(w);
          queue.push_back(w);
          if (snake.is_deformation_vertex(w)) found.push_back(w);
        }
      }
      for (int w : seen_list) seen[w] = 0;
      const int t = snake.template_id(v);
      if (found.empty()) {  // no deformation vertex reachable: the snake's own frame
        out.positions[v] = t >= 0 ? tmpl.positions[t] : q[v];
        continue;
      }
      double wsum = 0.0;
      Point<D> qc = Point<D>::Zero(), pc = Point<D>::Zero();
      std::vector<double> weight(found.size());
      for (size_t i = 0; i < found.size(); ++i) {
        const int w = found[i];
        weight[i] = 1.0 / ((q[w] - q[v]).squaredNorm() + eps2);
        wsum += weight[i];
        qc += weight[i] * q[w];
        pc += weight[i] * tmpl.positions[snake.template_id(w)];
      }
      qc /= wsum;
      pc /= wsum;
      Mat cross = Mat::Zero();
      double spread = 0.0;
      for (size_t i = 0; i < found.size(); ++i) {
        const int w = found[i];
        const Point<D> a = q[w] - qc, b = tmpl.positions[snake.template_id(w)] - pc;
        cross += weight[i] * b * a.transpose();
        spread += weight[i] * a.squaredNorm();
      }
      out.rotation[v] = best_rotation<D>(cross);
      if (t >= 0) {
        out.positions[v] = tmpl.positions[t];
      } else {
        out.positions[v] = pc + best_similarity<D>(cross, spread) * (q[v] - qc);
      }
    }
  }
  return out;
}

template RestPositions<2> rest_positions(const Template<2>&, const Snake<2>&, int);
template RestPositions<3> rest_positions(const Template<3>&, const Snake<3>&, int);

}  // namespace dsnake
