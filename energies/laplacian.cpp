// Laplacian surface editing energy; see laplacian.h. Sorkine et al., SGP 2004, §3 (the
// linearised similarity T_i and the energy of eq. (5) there).
// GCC 12 reports (at -O2) a false -Wmaybe-uninitialized inside Eigen's small dense eigen-solver
// (SelfadjointMatrixVector.h / TriangularMatrixVector.h); nothing in this file is uninitialised.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include "energies/laplacian.h"

#include "energies/block_quadratic.h"
#include "energies/mls_weights.h"
#include "energies/residual_blocks.h"
#include "framework/core/errors.h"
#include "framework/operators/mesh_operators.h"

#include <Eigen/Dense>
#include <cmath>


namespace dsnake {

template <int D>
struct LaplacianEnergy<D>::Data {
  const Template<D>* tmpl = nullptr;
  int n = 0;
  std::vector<std::vector<int>> support;           // per i: {i, ring...} (template ids)
  std::vector<std::vector<Block<D>>> coefficients;  // per i: r_i = sum_k C_k q_support[k]
  BlockQuadratic<D> quadratic;
  std::vector<int> vertex_of_id;
  int bound_vertices = -1;      // the snake's vertex count and topology version at the last bind
  uint64_t bound_version = 0;
  PointList<D> q, next;
};

template <int D>
LaplacianEnergy<D>::LaplacianEnergy(const LaplacianOptions& options) : options_(options), data_(std::make_unique<Data>()) {}

template <int D>
LaplacianEnergy<D>::~LaplacianEnergy() = default;

namespace {

// Rows of the linearised similarity acting on x: T x = s x + (h x x | h x^perp) + t, as a
// D x K matrix in the unknowns theta = (s, h, t), K = 4 (2D) or 7 (3D).
template <int D>
constexpr int kParams = 1 + (D == 2 ? 1 : 3) + D;

template <int D>
Eigen::Matrix<double, D, kParams<D>> similarity_rows(const Point<D>& x, bool with_translation) {
  Eigen::Matrix<double, D, kParams<D>> rows = Eigen::Matrix<double, D, kParams<D>>::Zero();
  rows.col(0) = x;
  if constexpr (D == 2) {
    rows(0, 1) = -x[1];
    rows(1, 1) = x[0];
  } else {  // h x x = -[x]_x h
    rows(0, 2) = x[2];  rows(0, 3) = -x[1];
    rows(1, 1) = -x[2]; rows(1, 3) = x[0];
    rows(2, 1) = x[1];  rows(2, 2) = -x[0];
  }
  if (with_translation) rows.rightCols(D).setIdentity();
  return rows;
}

}  // namespace

// Per vertex i: theta = G b (G the least-squares pseudo-inverse of the stacked similarity rows of the support
// points, b the stacked q), T_i delta_i = E theta, so r_i = E G b - L(q)_i, D x D blocks per
// support vertex. The pseudo-inverse gives the minimum-norm theta for a degenerate support.
template <int D>
void LaplacianEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  Data& d = *data_;
  const Template<D>* tmpl = context.tmpl ? context.tmpl : d.tmpl;
  DSNAKE_ASSERT(tmpl != nullptr, "laplacian is bound to a template");
  if (tmpl != d.tmpl || tmpl->num_vertices() != d.n) {
    d.tmpl = tmpl;
    const int n = d.n = tmpl->num_vertices();
    const Connectivity& c = tmpl->connectivity;
    const PointList<D>& p = tmpl->positions;
    d.support.assign(n, {});
    d.coefficients.assign(n, {});
    d.quadratic.reset(n);
    for (int i = 0; i < n; ++i) {
      const auto ring = c.neighbors(i);
      std::vector<int>& s = d.support[i];
      s.push_back(i);
      s.insert(s.end(), ring.begin(), ring.end());
      const int m = int(s.size());
      const Point<D> delta = umbrella_laplacian<D>(c, p, i);  // the template's delta-coordinate
      constexpr int K = kParams<D>;
      Eigen::Matrix<double, Eigen::Dynamic, K> a(D * m, K);
      for (int k = 0; k < m; ++k) a.middleRows(D * k, D) = similarity_rows<D>(p[s[k]], true);
      // minimum-norm least squares: G = (A^T A)^+ A^T, the pseudo-inverse of the small K x K
      // normal matrix by its eigen-decomposition (eigenvalues below 1e-12 of the largest dropped)
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, K, K>> eig(a.transpose() * a);
      const Eigen::Matrix<double, K, 1> lambda = eig.eigenvalues();
      Eigen::Matrix<double, K, 1> inverse = Eigen::Matrix<double, K, 1>::Zero();
      for (int k = 0; k < lambda.size(); ++k)
        if (lambda[k] > 1e-12 * lambda.maxCoeff()) inverse[k] = 1.0 / lambda[k];
      const Eigen::MatrixXd g = eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose() * a.transpose();
      const Eigen::MatrixXd eg = similarity_rows<D>(delta, false) * g;  // D x (D m)
      std::vector<Block<D>>& blocks = d.coefficients[i];
      blocks.assign(m, Block<D>::Zero());
      for (int k = 0; k < m; ++k) {
        blocks[k] = eg.middleCols(D * k, D);
        if (k == 0) blocks[k] -= Block<D>::Identity();
        else blocks[k] += Block<D>::Identity() / double(ring.size());
      }
      d.quadratic.add_residual(s, blocks);
    }
    d.quadratic.finalize();
    d.q.resize(n);
    d.next.resize(n);
  }
  map_template_vertices(snake, d.n, d.vertex_of_id);
  d.bound_vertices = snake.num_vertices();
  d.bound_version = snake.topology_version();
}

template <int D>
void LaplacianEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before propose()");
  DSNAKE_ASSERT(d.bound_vertices == snake.num_vertices() && d.bound_version == snake.topology_version(),
                "bound to the snake's topology (the phase driver rebinds after a remesh)");
  for (int t = 0; t < d.n; ++t) d.q[t] = snake.positions()[d.vertex_of_id[t]];
  if (options_.iteration == LaplacianIteration::kGaussSeidel) d.quadratic.gauss_seidel(d.q);
  else { d.quadratic.jacobi(d.q, d.next); std::swap(d.q, d.next); }
  for (int t = 0; t < d.n; ++t) out[d.vertex_of_id[t]] = d.q[t];
}

// Sum of the residuals' squares, serially (thread-count independent).
template <int D>
double LaplacianEnergy<D>::value(const Snake<D>& snake) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before value()");
  double e = 0.0;
  for (int i = 0; i < d.n; ++i) {
    Point<D> r = Point<D>::Zero();
    for (size_t k = 0; k < d.support[i].size(); ++k)
      r += d.coefficients[i][k] * snake.positions()[snake.vertex_of_template_id(d.support[i][k])];
    e += r.squaredNorm();
  }
  return e;
}

template <int D>
bool LaplacianEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before add_residuals()");
  for (int i = 0; i < d.n; ++i) {
    std::vector<int> vertices;
    for (int t : d.support[i]) vertices.push_back(snake.vertex_of_template_id(t));
    add_block_linear_residual<D>(problem, vertices, d.coefficients[i], std::sqrt(weight));
  }
  return true;
}

template class LaplacianEnergy<2>;
template class LaplacianEnergy<3>;

}  // namespace dsnake
