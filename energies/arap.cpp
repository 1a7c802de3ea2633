// ARAP energy; see arap.h. Sorkine & Alexa, SGP 2007, eqs. (3)-(9) with w_ij = 1.
#include "energies/arap.h"

#include "energies/mls_weights.h"
#include "energies/residual_blocks.h"
#include "framework/core/errors.h"

#include <cmath>

namespace dsnake {

template <int D>
struct ArapEnergy<D>::Data {
  using Matrix = Eigen::Matrix<double, D, D>;
  const Template<D>* tmpl = nullptr;
  int n = 0;
  std::vector<int> vertex_of_id;
  int bound_vertices = -1;      // the snake's vertex count and topology version at the last bind
  uint64_t bound_version = 0;
  PointList<D> q, next;
  std::vector<Matrix, Eigen::aligned_allocator<Matrix>> rotation;
};

template <int D>
ArapEnergy<D>::ArapEnergy(const ArapOptions&) : data_(std::make_unique<Data>()) {}

template <int D>
ArapEnergy<D>::~ArapEnergy() = default;

template <int D>
void ArapEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  Data& d = *data_;
  const Template<D>* tmpl = context.tmpl ? context.tmpl : d.tmpl;
  DSNAKE_ASSERT(tmpl != nullptr, "arap is bound to a template");
  d.tmpl = tmpl;
  d.n = tmpl->num_vertices();
  d.q.resize(d.n);
  d.next.resize(d.n);
  d.rotation.resize(d.n);
  map_template_vertices(snake, d.n, d.vertex_of_id);
  d.bound_vertices = snake.num_vertices();
  d.bound_version = snake.topology_version();
}

// Sorkine & Alexa eq. (6): R_i from the SVD of sum_j (q_i - q_j)(p_i - p_j)^T, det R_i = +1.
template <int D>
static Eigen::Matrix<double, D, D> optimal_rotation(const Template<D>& t, int i, const PointList<D>& q) {
  Eigen::Matrix<double, D, D> cross = Eigen::Matrix<double, D, D>::Zero();
  for (int j : t.connectivity.neighbors(i)) cross.noalias() += (q[i] - q[j]) * (t.positions[i] - t.positions[j]).transpose();
  return best_rotation<D>(cross);
}

template <int D>
void ArapEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before propose()");
  DSNAKE_ASSERT(d.bound_vertices == snake.num_vertices() && d.bound_version == snake.topology_version(),
                "bound to the snake's topology (the phase driver rebinds after a remesh)");
  const Template<D>& t = *d.tmpl;
  const int n = d.n;
  for (int k = 0; k < n; ++k) d.q[k] = snake.positions()[d.vertex_of_id[k]];
#pragma omp parallel for schedule(static) if (n >= 256)
  for (int i = 0; i < n; ++i) d.rotation[i] = optimal_rotation<D>(t, i, d.q);
  // Minimiser over q_k of its own term (targets q_j + R_k e_kj) and of the neighbours' terms
  // (targets q_j + R_j e_kj), e_kj = p_k - p_j; the adjacency is symmetric.
#pragma omp parallel for schedule(static) if (n >= 256)
  for (int k = 0; k < n; ++k) {
    const auto ring = t.connectivity.neighbors(k);
    if (ring.empty()) { d.next[k] = d.q[k]; continue; }
    Point<D> sum = Point<D>::Zero();
    for (int j : ring) sum += 2.0 * d.q[j] + (d.rotation[k] + d.rotation[j]) * (t.positions[k] - t.positions[j]);
    d.next[k] = sum / (2.0 * double(ring.size()));
  }
  for (int k = 0; k < n; ++k) out[d.vertex_of_id[k]] = d.next[k];
}

template <int D>
double ArapEnergy<D>::value(const Snake<D>& snake) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before value()");
  const Template<D>& t = *d.tmpl;
  PointList<D> q(d.n);
  for (int k = 0; k < d.n; ++k) q[k] = snake.positions()[snake.vertex_of_template_id(k)];
  double e = 0.0;
  for (int i = 0; i < d.n; ++i) {
    const auto r = optimal_rotation<D>(t, i, q);
    for (int j : t.connectivity.neighbors(i)) e += ((q[i] - q[j]) - r * (t.positions[i] - t.positions[j])).squaredNorm();
  }
  return e;
}

template <int D>
bool ArapEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before add_residuals()");
  const Template<D>& t = *d.tmpl;
  const double root = std::sqrt(weight);
  for (int i = 0; i < d.n; ++i) {
    const auto ring = t.connectivity.neighbors(i);
    if (ring.empty()) continue;
    // r_ij = (q_j - q_i) - R_i (p_j - p_i), R_i an auxiliary block started at its best fit.
    const int centre = snake.vertex_of_template_id(i);
    std::vector<int> others;
    PointList<D> a;
    Eigen::Matrix<double, D, D> cross = Eigen::Matrix<double, D, D>::Zero();
    for (int j : ring) {
      others.push_back(snake.vertex_of_template_id(j));
      a.push_back(t.positions[j] - t.positions[i]);
      cross.noalias() += (snake.positions()[others.back()] - snake.positions()[centre]) * a.back().transpose();
    }
    add_transform_residuals<D>(problem, centre, others, a, std::vector<double>(ring.size(), root), false,
                               best_rotation<D>(cross));
  }
  return true;
}

template class ArapEnergy<2>;
template class ArapEnergy<3>;

}  // namespace dsnake
