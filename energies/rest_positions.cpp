// Rest positions of free vertices by a local similarity fit; see rest_positions.h.
#include "energies/rest_positions.h"

#include "energies/mls_weights.h"
#include "framework/core/errors.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {

// The offset along the unit normal m that puts x on the weighted least-squares quadric height
// field w(u) = c0 + c1 u + c2 u^2 (2D) or c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2 (3D) through
// the template positions of `found`, in the frame of m at x; zero when the fit is not determined
// or the offset is larger than the points' mean distance (a fold, not a curved surface).
template <int D>
Point<D> onto_quadric(const Template<D>& tmpl, const Snake<D>& snake, const std::vector<int>& found,
                      const std::vector<double>& weight, const Point<D>& x, Point<D> m) {
  constexpr int kTerms = D == 2 ? 3 : 6;
  if (int(found.size()) < kTerms + 1 || !(m.norm() > 0)) return Point<D>::Zero();
  m.normalize();
  Point<D> t1, t2 = Point<D>::Zero();
  if constexpr (D == 2) {
    t1 = Point<D>(-m[1], m[0]);
  } else {
    const Point<D> a = std::abs(m[0]) < 0.9 ? Point<D>(1, 0, 0) : Point<D>(0, 1, 0);
    t1 = (a - a.dot(m) * m).normalized();
    t2 = m.cross(t1);
  }
  Eigen::Matrix<double, kTerms, kTerms> ata = Eigen::Matrix<double, kTerms, kTerms>::Zero();
  Eigen::Matrix<double, kTerms, 1> atb = Eigen::Matrix<double, kTerms, 1>::Zero();
  double reach = 0.0;
  for (size_t i = 0; i < found.size(); ++i) {
    const Point<D> d = tmpl.positions[snake.template_id(found[i])] - x;
    reach += d.norm();
    const double u = d.dot(t1), v = D == 3 ? d.dot(t2) : 0.0, w = d.dot(m);
    Eigen::Matrix<double, kTerms, 1> row;
    if constexpr (D == 2) row << 1, u, u * u;
    else row << 1, u, v, u * u, u * v, v * v;
    ata += weight[i] * row * row.transpose();
    atb += weight[i] * w * row;
  }
  reach /= double(found.size());
  Eigen::FullPivLU<Eigen::Matrix<double, kTerms, kTerms>> lu(ata);
  lu.setThreshold(1e-10);
  if (lu.rank() < kTerms) return Point<D>::Zero();
  const double c0 = lu.solve(atb)(0);
  if (!std::isfinite(c0) || std::abs(c0) > reach) return Point<D>::Zero();
  return c0 * m;
}

}  // namespace

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
  const PointList<D> normals = snake.vertex_normals();
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
        // The similarity carries a free vertex to the template's facets (a chord of the object
        // in the atlas, off its boundary by about L^2 / 8R on edges of length L); the quadric
        // through the nearest template vertices puts it back on the curved surface they sample.
        out.positions[v] += onto_quadric<D>(tmpl, snake, found, weight, out.positions[v],
                                            Point<D>(out.rotation[v] * normals[v]));
      }
    }
  }
  return out;
}

template RestPositions<2> rest_positions(const Template<2>&, const Snake<2>&, int);
template RestPositions<3> rest_positions(const Template<3>&, const Snake<3>&, int);

}  // namespace dsnake
