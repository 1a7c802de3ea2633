// Classical snake internal energy; see internal.h. Kass, Witkin, Terzopoulos, "Snakes: Active
// contour models" (1988), appendix; Levi & Gotsman, D-Snake, §1 (E_int) and §3.1 (q^int).
#include "energies/internal.h"

#include "framework/core/errors.h"
#include "framework/global/global_problem.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <span>
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
  // Chebyshev: A as one-ring stencils (mesh: neighbours and 1 / valence; polygon: Kass's band),
  // spectrum [lo, hi] of gamma I + A, iteration count, and n x D scratch.
  int iterations = 0;  // 0: direct
  double lo = 1, hi = 1;
  std::vector<int> ring_offsets, ring;
  std::vector<double> inverse_valence;
  PointList<D> x, r, d, d_next, ld;
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
    : options_(checked(options, kType)), solver_(std::make_unique<Solver>()) {}

namespace {

// Chebyshev iterations k with 1 / T_k(sigma) <= eps, sigma = (hi + lo) / (hi - lo): the error
// bound of the semi-iteration on a spectrum in [lo, hi] (Saad, Iterative Methods, §12.3).
int chebyshev_count(double lo, double hi, double eps) {
  if (!(hi > lo)) return 0;
  const double sigma = (hi + lo) / (hi - lo);
  return std::max(1, static_cast<int>(std::ceil(std::acosh(1.0 / eps) / std::acosh(sigma))));
}

}  // namespace

template <int D>
int InternalEnergy<D>::chebyshev_iterations() const {
  return solver_->iterations;
}

template <int D>
InternalEnergy<D>::~InternalEnergy() = default;

template <int D>
void InternalEnergy<D>::bind(const EnergyContext<D>&, const Snake<D>& snake) {
  const Connectivity& c = snake.connectivity();
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(n == c.num_vertices() && n >= 3, "a closed polygon or mesh of >= 3 vertices");
  Solver& s = *solver_;
  s.topology_version = snake.topology_version();
  s.num_vertices = n;
  // Chebyshev: the error in the valence-weighted norm ||e||_W (A is self-adjoint in it) shrinks by
  // 1 / T_k(sigma); ||e||_inf <= ||e||_W / sqrt(w_min) and ||e_0||_W <= sqrt(sum w) ||e_0||_inf turn
  // the tolerance on the largest vertex error into eps.
  const bool polygon = c.is_polygon();
  const double a = options_.alpha, b = options_.beta;
  s.lo = options_.gamma;
  s.hi = options_.gamma + (polygon ? 4 * a + 16 * b : 2 * a + 4 * b);
  double weight_sum = 0, weight_min = 1e300;
  for (int v = 0; v < n; ++v) {
    const double w = polygon ? 1.0 : ring_weight(c, v);
    weight_sum += w;
    weight_min = std::min(weight_min, w);
  }
  const int count = chebyshev_count(s.lo, s.hi, options_.tolerance / std::sqrt(weight_sum / weight_min));
  const bool chebyshev = options_.solver == InternalSolver::kChebyshev || (options_.solver == InternalSolver::kAuto && !polygon && count <= 32);
  s.iterations = chebyshev ? std::max(count, 1) : 0;
  if (chebyshev) {
    s.ring_offsets.assign(1, 0);
    s.ring.clear();
    s.inverse_valence.resize(n);
    for (int v = 0; v < n; ++v) {
      const auto ring = c.neighbors(v);
      s.ring.insert(s.ring.end(), ring.begin(), ring.end());
      s.ring_offsets.push_back(static_cast<int>(s.ring.size()));
      s.inverse_valence[v] = 1.0 / ring_weight(c, v);
    }
    for (PointList<D>* p : {&s.x, &s.r, &s.d, &s.d_next, &s.ld}) p->assign(n, Point<D>::Zero());
    return;
  }
  SparseMatrix system;
  if (polygon) {
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
}

// Kass 1988, eqs. (19)-(20) without the external term: x_t = (A + gamma I)^{-1} (gamma x_{t-1}).
// The solve P^T L^{-T} D^{-1} L^{-1} P is spelled out over L's compressed columns with a D-vector
// per row, so that L is read once for all coordinates (Eigen's triangular solves take one
// right-hand column at a time, three passes over L) and nothing is allocated.
template <int D>
void InternalEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  Solver& s = *solver_;
  DSNAKE_ASSERT(s.num_vertices == snake.num_vertices() && s.topology_version == snake.topology_version(),
                "bound to the snake's topology (the phase driver rebinds after a remesh)");
  DSNAKE_ASSERT(int(out.size()) == snake.num_vertices(), "out has one entry per vertex");
  if (s.iterations > 0)
    propose_chebyshev(snake, out);
  else
    propose_direct(snake, out);
}

template <int D>
void InternalEnergy<D>::propose_direct(const Snake<D>& snake, PointList<D>& out) {
  Solver& s = *solver_;
  const int n = snake.num_vertices();
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

// The same step by Chebyshev semi-iteration (Saad, Iterative Methods, Alg. 12.1) on
// (gamma I + A) x = gamma q from x0 = q, with A's spectrum bounds in place of inner products:
//   r0 = gamma q - M q, d0 = r0 / theta; x += d; r -= M d; d = rho' rho d + 2 rho' / delta r.
// A is applied as stencils: on a mesh (L y)_v = y_v - mean of y over v's one-ring and
// A = alpha L + beta L^2 (two passes when beta > 0); on a polygon Kass's five-point band. Every
// pass writes per vertex only, so 1 and 2 threads give the same bits.
template <int D>
void InternalEnergy<D>::propose_chebyshev(const Snake<D>& snake, PointList<D>& out) {
  Solver& s = *solver_;
  const int n = snake.num_vertices();
  const PointList<D>& q = snake.positions();
  const double gamma = options_.gamma, alpha = options_.alpha, beta = options_.beta;
  const double theta = 0.5 * (s.hi + s.lo), delta = 0.5 * (s.hi - s.lo), sigma = theta / delta;
  const int* offsets = s.ring_offsets.data();
  const int* ring = s.ring.data();
  const double* inv_val = s.inverse_valence.data();
  // The polygon's D1^T D1 = 2 y_v - y_{v-1} - y_{v+1} is twice the umbrella over {v-1, v+1}.
  const double lap_scale = snake.connectivity().is_polygon() ? 2.0 : 1.0;
  PointList<D>&x = s.x, &r = s.r, &ld = s.ld;
  // (L y)_v = y_v - mean of y over v's ring (times 2 on a polygon); 0 for an isolated vertex.
  auto laplacian = [=](const PointList<D>& y, int v) -> Point<D> {
    Point<D> sum = Point<D>::Zero();
    for (int k = offsets[v]; k < offsets[v + 1]; ++k) sum += y[ring[k]];
    return lap_scale * (y[v] - inv_val[v] * sum) * (offsets[v + 1] > offsets[v] ? 1.0 : 0.0);
  };
  // (M y)_v = gamma y_v + alpha (L y)_v + beta (L (L y))_v with ly = L y for all vertices
  // (on a polygon D2^T D2 = (D1^T D1)^2 for the cyclic differences).
  auto apply = [&](const PointList<D>& y, const PointList<D>& ly, int v) -> Point<D> {
    Point<D> m = gamma * y[v] + alpha * ly[v];
    if (beta > 0) m += beta * laplacian(ly, v);
    return m;
  };
  const int iterations = s.iterations;
  const bool parallel = n >= 256;
#pragma omp parallel if (parallel)
  {
    double rho = 1.0 / sigma;  // per thread: every thread runs the same scalar recurrence
    // x0 = q, r0 = gamma q - M q, d0 = r0 / theta.
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v) ld[v] = laplacian(q, v);
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v) {
      x[v] = q[v];
      r[v] = gamma * q[v] - apply(q, ld, v);
      s.d[v] = r[v] / theta;
    }
    for (int k = 0; k < iterations; ++k) {
      const double rho_next = 1.0 / (2.0 * sigma - rho);
      // d_k and d_{k+1} alternate between the two buffers: no shared swap, no extra barrier
      const PointList<D>& d = k % 2 == 0 ? s.d : s.d_next;
      PointList<D>& d_next = k % 2 == 0 ? s.d_next : s.d;
      if (k + 1 < iterations) {
        if (beta > 0) {
#pragma omp for schedule(static)
          for (int v = 0; v < n; ++v) ld[v] = laplacian(d, v);
        }
#pragma omp for schedule(static)
        for (int v = 0; v < n; ++v) {
          const Point<D> md = beta > 0 ? apply(d, ld, v) : Point<D>(gamma * d[v] + alpha * laplacian(d, v));
          r[v] -= md;
          x[v] += d[v];
          d_next[v] = rho_next * rho * d[v] + (2.0 * rho_next / delta) * r[v];
        }
      } else {
#pragma omp for schedule(static) nowait
        for (int v = 0; v < n; ++v) out[v] = x[v] + d[v];
      }
      rho = rho_next;
    }
  }
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
