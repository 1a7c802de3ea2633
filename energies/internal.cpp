// Classical snake internal energy; see internal.h. Kass, Witkin, Terzopoulos, "Snakes: Active
// contour models" (1988), appendix; Levi & Gotsman, D-Snake, §1 (E_int) and §3.1 (q^int).
#include "energies/internal.h"

#include "framework/errors.h"
#include "framework/global_problem.h"

#include <Eigen/SparseCholesky>
#include <cmath>
#include <Eigen/SparseCore>
#include <vector>

namespace dsnake {

namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;

// 2D, Kass 1988 appendix: the cyclic pentadiagonal A with rows
// (beta, -alpha-4beta, 2alpha+6beta, -alpha-4beta, beta) = alpha D1^T D1 + beta D2^T D2 (D1, D2 the
// cyclic first and second differences). Returns gamma I + A; duplicate entries (n < 5, where
// the band wraps onto itself) are summed, which is the circulant product folded mod n.
SparseMatrix polygon_system(int n, const InternalOptions& o) {
  const double band[5] = {o.beta, -o.alpha - 4 * o.beta, 2 * o.alpha + 6 * o.beta + o.gamma,
                          -o.alpha - 4 * o.beta, o.beta};
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(5 * n);
  for (int i = 0; i < n; ++i)
    for (int k = -2; k <= 2; ++k)
      if (band[k + 2] != 0.0) entries.emplace_back(i, ((i + k) % n + n) % n, band[k + 2]);
  SparseMatrix m(n, n);
  m.setFromTriplets(entries.begin(), entries.end());
  return m;
}

// Number of one-ring neighbours used to normalise the umbrella operator (1 for an isolated
// vertex, whose Laplacian row is zero).
double ring_weight(const Connectivity& c, int v) {
  const auto ring = c.neighbors(v);
  return ring.empty() ? 1.0 : static_cast<double>(ring.size());
}

// 3D: gamma I + alpha L + beta L^2 with the umbrella L = W^{-1} Lc (W = diag(valence), Lc = W - adjacency
// the combinatorial Laplacian) is not symmetric, but W times it is symmetric positive definite:
//   W (gamma I + alpha L + beta L^2) = gamma W + alpha Lc + beta Lc W^{-1} Lc,
// so the step solves that system (right-hand side gamma W q) with a sparse LDL^T. Same solution,
// half the work of an LU and a symmetric ordering.
SparseMatrix mesh_system(const Connectivity& c, const InternalOptions& o, Eigen::VectorXd& weights) {
  const int n = c.num_vertices();
  weights.resize(n);
  std::vector<Eigen::Triplet<double>> entries;
  for (int v = 0; v < n; ++v) {
    const auto ring = c.neighbors(v);
    weights[v] = ring_weight(c, v);
    entries.emplace_back(v, v, static_cast<double>(ring.size()));
    for (int w : ring) entries.emplace_back(v, w, -1.0);
  }
  SparseMatrix lc(n, n);
  lc.setFromTriplets(entries.begin(), entries.end());
  const Eigen::VectorXd inverse_weights = weights.cwiseInverse();
  SparseMatrix wm(n, n);
  wm.setIdentity();
  wm = wm * weights.asDiagonal();
  SparseMatrix bilaplacian = lc * inverse_weights.asDiagonal() * lc;
  SparseMatrix m = o.gamma * wm + o.alpha * lc + o.beta * bilaplacian;
  m.prune(0.0);
  const SparseMatrix mt = m.transpose();
  DSNAKE_ASSERT((m - mt).norm() <= 1e-12 * (1.0 + m.norm()),
                "the mesh adjacency is symmetric (every edge is in both one-rings)");
  return m;
}

}  // namespace

// K x = gamma S q with K = S (gamma I + A) symmetric positive definite (S = I in 2D, W in 3D),
// factorised once per topology, plus n x D scratch so that propose() allocates nothing.
template <int D>
struct InternalEnergy<D>::Solver {
  Eigen::SimplicialLDLT<SparseMatrix> ldlt;
  Eigen::VectorXd row_scale;  // S, n entries
  Eigen::VectorXd inverse_d;  // 1 / D of the LDL^T (vectorD() returns a copy)
  PointList<D> points;        // n, in the factorisation's order: one pass over L for all D columns
  std::vector<int> order;     // order[v] = row of vertex v in the permuted system
  uint64_t topology_version = 0;
  int num_vertices = -1;
};

template <int D>
InternalEnergy<D>::InternalEnergy(const InternalOptions& options)
    : options_(options), solver_(std::make_unique<Solver>()) {
  DSNAKE_ASSERT(options.alpha >= 0 && options.beta >= 0 && options.gamma > 0,
                "internal energy options: alpha >= 0, beta >= 0, gamma > 0");
}

template <int D>
InternalEnergy<D>::~InternalEnergy() = default;

template <int D>
void InternalEnergy<D>::bind(const EnergyContext<D>&, const Snake<D>& snake) {
  const Connectivity& c = snake.connectivity();
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(n == c.num_vertices() && n >= 3, "a closed polygon or mesh of >= 3 vertices");
  Solver& s = *solver_;
  SparseMatrix system;
  if (c.is_polygon()) {
    system = polygon_system(n, options_);
    s.row_scale = Eigen::VectorXd::Ones(n);
  } else {
    system = mesh_system(c, options_, s.row_scale);
  }
  s.ldlt.compute(system);
  DSNAKE_ASSERT(s.ldlt.info() == Eigen::Success, "gamma I + A is positive definite");
  s.inverse_d = s.ldlt.vectorD().cwiseInverse();
  s.points.assign(n, Point<D>::Zero());
  s.order.resize(n);
  const auto& perm = s.ldlt.permutationP().indices();
  for (int v = 0; v < n; ++v) s.order[v] = perm.size() == n ? perm[v] : v;
  s.topology_version = snake.topology_version();
  s.num_vertices = n;
}

// Kass 1988, eqs. (19)-(20) without the external term: x_t = (A + gamma I)^{-1} (gamma x_{t-1}).
// The solve P^T L^{-T} D^{-1} L^{-1} P is spelled out over L's compressed columns with a D-vector
// per row, so that L is read once for all coordinates (Eigen's triangular solves take one
// right-hand column at a time, three passes over L) and nothing is allocated.
template <int D>
void InternalEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  Solver& s = *solver_;
  if (s.num_vertices != snake.num_vertices() || s.topology_version != snake.topology_version())
    bind(EnergyContext<D>{}, snake);
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(int(out.size()) == n, "out has one entry per vertex");
  const PointList<D>& q = snake.positions();
  PointList<D>& y = s.points;
  for (int v = 0; v < n; ++v) y[s.order[v]] = options_.gamma * s.row_scale[v] * q[v];
  // L is unit lower triangular, stored by columns without its diagonal (Eigen's LDL^T layout).
  const SparseMatrix& L = s.ldlt.matrixL().nestedExpression();
  for (int i = 0; i < n; ++i)  // forward: L y = b
    for (typename SparseMatrix::InnerIterator it(L, i); it; ++it) y[it.row()] -= it.value() * y[i];
  for (int i = 0; i < n; ++i) y[i] *= s.inverse_d[i];
  for (int i = n - 1; i >= 0; --i)  // backward: L^T x = y
    for (typename SparseMatrix::InnerIterator it(L, i); it; ++it) y[i] -= it.value() * y[it.row()];
  for (int v = 0; v < n; ++v) out[v] = y[s.order[v]];
}

// Kass 1988 eq. (1)'s E_int, discretised with unit parameter steps (see internal.h).
template <int D>
double InternalEnergy<D>::value(const Snake<D>& snake) const {
  const PointList<D>& q = snake.positions();
  const Connectivity& c = snake.connectivity();
  const int n = snake.num_vertices();
  const double alpha = options_.alpha, beta = options_.beta;
  double e = 0.0;
  if (c.is_polygon()) {
    for (int i = 0; i < n; ++i) {
      const Point<D>& prev = q[(i + n - 1) % n];
      const Point<D>& next = q[(i + 1) % n];
      e += 0.5 * alpha * (next - q[i]).squaredNorm();
      e += 0.5 * beta * (next - 2.0 * q[i] + prev).squaredNorm();
    }
    return e;
  }
  for (int v = 0; v < n; ++v) {
    const auto ring = c.neighbors(v);
    Point<D> mean = Point<D>::Zero();
    for (int w : ring) {
      if (w > v) e += 0.5 * alpha * (q[v] - q[w]).squaredNorm();  // each edge once
      mean += q[w];
    }
    if (!ring.empty()) e += 0.5 * beta * (q[v] - mean / double(ring.size())).squaredNorm();
  }
  return e;
}

template <int D>
bool InternalEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  const Connectivity& c = snake.connectivity();
  const int n = snake.num_vertices();
  const double sa = std::sqrt(0.5 * weight * options_.alpha), sb = std::sqrt(0.5 * weight * options_.beta);
  std::vector<int> vertices;
  std::vector<double> coefficients;
  for (int v = 0; v < n; ++v) {
    const auto ring = c.neighbors(v);
    if (sa > 0) {  // each edge once: (v, next) on a polygon, (v, w > v) on a mesh
      for (int w : ring) {
        if (c.is_polygon() ? w != ring[1] : w < v) continue;
        const int pair[2] = {w, v};
        const double diff[2] = {1.0, -1.0};
        problem.add_linear_residual(pair, diff, sa);
      }
    }
    if (sb > 0) {  // q_v - mean(ring), times ring size 2 on a polygon: the second difference
      vertices.assign(1, v);
      const double k = c.is_polygon() ? 2.0 : 1.0;
      coefficients.assign(1, k);
      for (int w : ring) {
        vertices.push_back(w);
        coefficients.push_back(-k / double(ring.size()));
      }
      problem.add_linear_residual(vertices, coefficients, sb);
    }
  }
  return true;
}

template class InternalEnergy<2>;
template class InternalEnergy<3>;

}  // namespace dsnake
