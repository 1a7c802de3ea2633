// Classical snake internal energy; see internal.h. Kass, Witkin, Terzopoulos, "Snakes: Active
// contour models" (1988), appendix; Levi & Gotsman, D-Snake, §1 (E_int) and §3.1 (q^int); the
// physical form's step as in Desbrun, Meyer, Schroeder, Barr, "Implicit fairing" (1999).
#include "energies/internal.h"

#include "framework/core/errors.h"
#include "framework/global/global_problem.h"
#include "framework/operators/mesh_operators.h"

#include <Eigen/Geometry>
#include <Eigen/OrderingMethods>
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

// 3D: gamma I + alpha L + beta L^2 with the umbrella L = W^{-1} Lc (W = diag(valence), Lc = W - adjacency
// the combinatorial Laplacian) is not symmetric, but W times it is symmetric positive definite:
//   W (gamma I + alpha L + beta L^2) = gamma W + alpha Lc + beta Lc W^{-1} Lc,
// so the step solves that system (right-hand side gamma W q) with a sparse LDL^T. Same solution,
// half the work of an LU and a symmetric ordering.
SparseMatrix mesh_system(const Connectivity& c, const InternalOptions& o, Eigen::VectorXd& weights) {
  const int n = c.num_vertices();
  weights.resize(n);
  for (int v = 0; v < n; ++v) weights[v] = umbrella_weight(c, v);
  const SparseMatrix lc = combinatorial_laplacian(c);
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

// Index of entry (row, col) in a compressed column-major matrix's value array (asserted present).
int value_index(const SparseMatrix& m, int row, int col) {
  const int* begin = m.innerIndexPtr() + m.outerIndexPtr()[col];
  const int* end = m.innerIndexPtr() + m.outerIndexPtr()[col + 1];
  const int* it = std::lower_bound(begin, end, row);
  DSNAKE_ASSERT(it != end && *it == row, "the entry is in the system's pattern");
  return int(it - m.innerIndexPtr());
}

// Eigen's LDL^T of a matrix given in its fill-reducing order (upper triangle stored, so that
// factorize() reads it in place), with D read in place (vectorD() returns a copy).
class PreorderedLdlt : public Eigen::SimplicialLDLT<SparseMatrix, Eigen::Upper, Eigen::NaturalOrdering<int>> {
 public:
  const Eigen::VectorXd& diagonal() const { return m_diag; }
};

}  // namespace

// Umbrella: K x = gamma S q with K = S (gamma I + A) symmetric positive definite (S = I in 2D, W
// in 3D), factorised once per topology, plus n x D scratch so that propose() allocates nothing.
// Physical: the system's pattern, ordering and symbolic factorisation per topology, its values
// refilled and refactorised every step.
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
  // Physical: the elements (D vertices each); K's rows (row v: k_cols[k_offsets[v]...], v first);
  // each element entry's slot in K; where each K slot adds into the permuted upper system's values
  // (top-left block, -1: in the lower half; with beta, the coupling block K of row v, column n + w),
  // and where each diagonal does (top-left; with beta, the bottom-right -M / beta).
  bool physical = false;
  std::vector<int> elements, k_offsets, k_cols, element_slots, k_to_system, k_to_coupling, system_diagonal,
      auxiliary_diagonal;
  std::vector<double> local, mass, k_values;
  SparseMatrix system;
  PreorderedLdlt physical_ldlt;
  int cg_iterations = 0;  // of the last physical step with beta = 0 (0: solved directly)
  std::vector<double> cg_inverse_diagonal;
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
int InternalEnergy<D>::conjugate_gradient_iterations() const {
  return solver_->cg_iterations;
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
  s.physical = options_.discretization == InternalDiscretization::kPhysical;
  if (s.physical)
    bind_physical(snake);
  else
    bind_umbrella(snake);
}

template <int D>
void InternalEnergy<D>::bind_umbrella(const Snake<D>& snake) {
  const Connectivity& c = snake.connectivity();
  const int n = snake.num_vertices();
  Solver& s = *solver_;
  // Chebyshev: the error in the valence-weighted norm ||e||_W (A is self-adjoint in it) shrinks by
  // 1 / T_k(sigma); ||e||_inf <= ||e||_W / sqrt(w_min) and ||e_0||_W <= sqrt(sum w) ||e_0||_inf turn
  // the tolerance on the largest vertex error into eps.
  const bool polygon = c.is_polygon();
  const double a = options_.alpha, b = options_.beta;
  s.lo = options_.gamma;
  s.hi = options_.gamma + (polygon ? 4 * a + 16 * b : 2 * a + 4 * b);
  double weight_sum = 0, weight_min = 1e300;
  for (int v = 0; v < n; ++v) {
    const double w = polygon ? 1.0 : umbrella_weight(c, v);
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
      s.inverse_valence[v] = 1.0 / umbrella_weight(c, v);
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

// The physical system's structure (internal.h). Without rigidity, gamma M + alpha K on K's
// pattern. With beta > 0 the step is solved in the mixed form of 2n unknowns (x, y = beta M^-1 K x)
//   [gamma M + alpha K   K        ] [x]   [gamma M q]
//   [K                  -M / beta ] [y] = [0        ],
// symmetric quasi-definite (Vanderbei 1995: an LDL^T exists in every symmetric order), whose
// pattern is two copies of the one-ring instead of the two-ring of K M^-1 K (3-5x less fill).
// Then the AMD ordering, the upper triangle in that order, the slots every step adds into, and
// the symbolic factorisation.
template <int D>
void InternalEnergy<D>::bind_physical(const Snake<D>& snake) {
  const Connectivity& c = snake.connectivity();
  const int n = snake.num_vertices();
  Solver& s = *solver_;
  s.iterations = 0;
  s.elements = element_vertices<D>(c);
  s.k_offsets.assign(1, 0);
  s.k_cols.clear();
  for (int v = 0; v < n; ++v) {
    s.k_cols.push_back(v);
    for (int w : c.neighbors(v)) s.k_cols.push_back(w);
    s.k_offsets.push_back(int(s.k_cols.size()));
  }
  auto slot = [&](int v, int w) {
    const auto begin = s.k_cols.begin() + s.k_offsets[v], end = s.k_cols.begin() + s.k_offsets[v + 1];
    const auto it = std::find(begin, end, w);
    DSNAKE_ASSERT(it != end, "an element's vertices are one-ring neighbours");
    return int(it - s.k_cols.begin());
  };
  s.element_slots.clear();
  for (size_t e = 0; e < s.elements.size(); e += D)
    for (int i = 0; i < D; ++i)
      for (int j = 0; j < D; ++j) s.element_slots.push_back(slot(s.elements[e + i], s.elements[e + j]));
  const bool mixed = options_.beta > 0;
  const int rows = mixed ? 2 * n : n;
  std::vector<Eigen::Triplet<double>> pattern;
  for (int k = 0; k < n; ++k) {
    if (mixed) pattern.emplace_back(n + k, n + k, 1.0);
    for (int p = s.k_offsets[k]; p < s.k_offsets[k + 1]; ++p) {
      pattern.emplace_back(k, s.k_cols[p], 1.0);
      if (mixed) pattern.emplace_back(k, n + s.k_cols[p], 1.0), pattern.emplace_back(n + s.k_cols[p], k, 1.0);
    }
  }
  SparseMatrix full(rows, rows);
  full.setFromTriplets(pattern.begin(), pattern.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
  Eigen::AMDOrdering<int>()(full, inverse);
  const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation = inverse.inverse();
  s.order.assign(permutation.indices().data(), permutation.indices().data() + rows);
  std::vector<Eigen::Triplet<double>> upper;
  for (const auto& t : pattern)
    if (s.order[t.row()] <= s.order[t.col()]) upper.emplace_back(s.order[t.row()], s.order[t.col()], 1.0);
  s.system.resize(rows, rows);
  s.system.setFromTriplets(upper.begin(), upper.end());
  s.system.makeCompressed();
  auto system_index = [&](int v, int w) {  // the upper entry of the pair {v, w}: -1 from its lower half
    const int a = s.order[v], b = s.order[w];
    return a <= b ? value_index(s.system, a, b) : -1;
  };
  auto pair_index = [&](int v, int w) { return std::max(system_index(v, w), system_index(w, v)); };
  s.k_to_system.resize(s.k_cols.size());
  s.k_to_coupling.assign(mixed ? s.k_cols.size() : 0, -1);
  s.system_diagonal.resize(n);
  s.auxiliary_diagonal.assign(mixed ? n : 0, -1);
  for (int k = 0; k < n; ++k) {
    s.system_diagonal[k] = system_index(k, k);
    if (mixed) s.auxiliary_diagonal[k] = system_index(n + k, n + k);
    for (int p = s.k_offsets[k]; p < s.k_offsets[k + 1]; ++p) {
      s.k_to_system[p] = system_index(k, s.k_cols[p]);
      if (mixed) s.k_to_coupling[p] = pair_index(k, n + s.k_cols[p]);
    }
  }
  s.physical_ldlt.analyzePattern(s.system);
  s.k_values.assign(s.k_cols.size(), 0.0);
  s.local.assign(s.elements.size() * D, 0.0);
  s.mass.assign(n, 0.0);
  s.points.assign(rows, Point<D>::Zero());
  s.inverse_d.resize(rows);
  for (PointList<D>* p : {&s.x, &s.r, &s.d, &s.d_next, &s.ld}) p->assign(n, Point<D>::Zero());  // CG scratch
}

namespace {

// x = P^T L^-T D^-1 L^-1 P (gamma S q) for a factorisation L D L^T of P (S (gamma I + A)) P^T
// (order[v] = row of vertex v in the permuted system, S = row_scale; rows past q's are the mixed
// form's auxiliary unknowns, right-hand side 0, not returned), spelled out over L's
// compressed columns with a D-vector per row, so that L is read once for all coordinates (Eigen's
// triangular solves take one right-hand column at a time, three passes over L) and nothing is
// allocated. y: n scratch points.
template <int D>
void ldlt_solve(const SparseMatrix& L, const Eigen::VectorXd& inverse_d, const std::vector<int>& order,
                const double* row_scale, double gamma, const PointList<D>& q, PointList<D>& y, PointList<D>& out) {
  const int n = int(L.rows());  // q.size(), or 2 q.size() for the physical mixed form (rhs 0 below)
  for (int v = 0; v < int(q.size()); ++v) y[order[v]] = gamma * row_scale[v] * q[v];
  for (int v = int(q.size()); v < n; ++v) y[order[v]] = Point<D>::Zero();
  // L is unit lower triangular, stored by columns without its diagonal (Eigen's LDL^T layout).
  for (int i = 0; i < n; ++i)  // forward: L y = b
    for (typename SparseMatrix::InnerIterator it(L, i); it; ++it) y[it.row()] -= it.value() * y[i];
  for (int i = 0; i < n; ++i) y[i] *= inverse_d[i];
  for (int i = n - 1; i >= 0; --i)  // backward: L^T x = y
    for (typename SparseMatrix::InnerIterator it(L, i); it; ++it) y[i] -= it.value() * y[it.row()];
  for (int v = 0; v < int(q.size()); ++v) out[v] = y[order[v]];
}

}  // namespace

// Kass 1988, eqs. (19)-(20) without the external term: x_t = (A + gamma I)^{-1} (gamma x_{t-1}).
template <int D>
void InternalEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  Solver& s = *solver_;
  DSNAKE_ASSERT(s.num_vertices == snake.num_vertices() && s.topology_version == snake.topology_version(),
                "bound to the snake's topology (the phase driver rebinds after a remesh)");
  DSNAKE_ASSERT(int(out.size()) == snake.num_vertices(), "out has one entry per vertex");
  if (s.physical)
    propose_physical(snake, out);
  else if (s.iterations > 0)
    propose_chebyshev(snake, out);
  else
    propose_direct(snake, out);
}

template <int D>
void InternalEnergy<D>::propose_direct(const Snake<D>& snake, PointList<D>& out) {
  Solver& s = *solver_;
  ldlt_solve<D>(s.ldlt.matrixL().nestedExpression(), s.inverse_d, s.order, s.row_scale.data(), options_.gamma,
                snake.positions(), s.points, out);
}

namespace {

// Scratch of conjugate_gradient (n points each): the iterate, residual, preconditioned residual,
// search direction and the operator applied to it.
template <int D>
struct CgScratch {
  PointList<D>&x, &r, &z, &p, &ap;
  std::vector<double>& inverse_diagonal;  // the Jacobi preconditioner, found once per solve
};

// The physical step with beta = 0, (gamma M + alpha K) x = gamma M q, by conjugate gradients
// preconditioned with the diagonal (Saad, Iterative Methods, Alg. 9.1), from x0 = q, on the D
// coordinates at once (the operator acts on each; the inner products sum over them). K is given
// by rows (row v: cols[offsets[v]...] with v first, values k). The system is symmetric positive
// definite and well conditioned for a snake's step (its spectrum, relative to gamma M, is
// [1, 1 + alpha lambda_max(M^-1 K) / gamma]), so a few tens of one-ring passes replace a
// numeric refactorisation. Serial, in a fixed order: the same bits on any thread count. Stops
// when |r| <= tolerance |r0| (r0 = -alpha K q, the internal force); returns the iterations, or 0
// if 500 do not get there (the caller then solves directly).
template <int D>
int conjugate_gradient(const std::vector<int>& offsets, const std::vector<int>& cols, const std::vector<double>& k,
                       const std::vector<double>& mass, double alpha, double gamma, double tolerance,
                       const PointList<D>& q, CgScratch<D>& s) {
  const int n = static_cast<int>(q.size());
  auto apply = [&](const PointList<D>& y, int v) {
    Point<D> sum = gamma * mass[v] * y[v];
    for (int j = offsets[v]; j < offsets[v + 1]; ++j) sum += alpha * k[j] * y[cols[j]];
    return sum;
  };
  std::vector<double>& inverse_diagonal = s.inverse_diagonal;
  inverse_diagonal.resize(n);
  for (int v = 0; v < n; ++v) inverse_diagonal[v] = 1.0 / (gamma * mass[v] + alpha * k[offsets[v]]);
  double rz = 0, r0 = 0;
  for (int v = 0; v < n; ++v) {
    s.x[v] = q[v];
    s.r[v] = gamma * mass[v] * q[v] - apply(q, v);
    s.z[v] = inverse_diagonal[v] * s.r[v];
    s.p[v] = s.z[v];
    rz += s.r[v].dot(s.z[v]);
    r0 += s.r[v].squaredNorm();
  }
  const double stop = tolerance * tolerance * r0;
  if (!(r0 > 0)) return r0 == 0 ? 1 : 0;  // q is the solution (or not finite: direct)
  for (int it = 1; it <= 500; ++it) {
    double pap = 0;
    for (int v = 0; v < n; ++v) {
      s.ap[v] = apply(s.p, v);
      pap += s.p[v].dot(s.ap[v]);
    }
    const double a = rz / pap;
    double rz_next = 0, rr = 0;
    for (int v = 0; v < n; ++v) {
      s.x[v] += a * s.p[v];
      s.r[v] -= a * s.ap[v];
      s.z[v] = inverse_diagonal[v] * s.r[v];
      rz_next += s.r[v].dot(s.z[v]);
      rr += s.r[v].squaredNorm();
    }
    if (rr <= stop) return it;
    if (!std::isfinite(rr)) return 0;
    const double b = rz_next / rz;
    rz = rz_next;
    for (int v = 0; v < n; ++v) s.p[v] = s.z[v] + b * s.p[v];
  }
  return 0;
}

}  // namespace

// The physical step (internal.h): M and K of the current positions, then
// (gamma M + alpha K + beta K M^-1 K) x = gamma M q (with beta, in its mixed form; bind_physical)
// assembled into the bound pattern (serially, in a fixed order), refactorised numerically and solved.
template <int D>
void InternalEnergy<D>::propose_physical(const Snake<D>& snake, PointList<D>& out) {
  Solver& s = *solver_;
  const int n = snake.num_vertices();
  const double alpha = options_.alpha, beta = options_.beta, gamma = options_.gamma;
  s.cg_iterations = 0;
  if (alpha == 0 && beta == 0) {  // gamma M x = gamma M q: x = q, exactly
    std::copy(snake.positions().begin(), snake.positions().end(), out.begin());
    return;
  }
  element_stiffness_and_mass<D>(snake.positions(), s.elements, s.local, s.mass);
  std::fill(s.k_values.begin(), s.k_values.end(), 0.0);
  for (size_t k = 0; k < s.local.size(); ++k) s.k_values[s.element_slots[k]] += s.local[k];
  if (beta == 0 && options_.solver != InternalSolver::kDirect) {
    CgScratch<D> scratch{s.x, s.r, s.d, s.d_next, s.ld, s.cg_inverse_diagonal};
    s.cg_iterations = conjugate_gradient<D>(s.k_offsets, s.k_cols, s.k_values, s.mass, alpha, gamma,
                                            options_.tolerance, snake.positions(), scratch);
    if (s.cg_iterations > 0) {
      std::copy(s.x.begin(), s.x.end(), out.begin());
      return;
    }  // not converged within the cap: the direct solve below
  }
  double* a = s.system.valuePtr();
  std::fill(a, a + s.system.nonZeros(), 0.0);
  for (int v = 0; v < n; ++v) a[s.system_diagonal[v]] += gamma * s.mass[v];
  for (size_t p = 0; p < s.k_values.size(); ++p)
    if (s.k_to_system[p] >= 0) a[s.k_to_system[p]] += alpha * s.k_values[p];
  for (size_t p = 0; p < s.k_to_coupling.size(); ++p) a[s.k_to_coupling[p]] += s.k_values[p];
  for (size_t v = 0; v < s.auxiliary_diagonal.size(); ++v) a[s.auxiliary_diagonal[v]] -= s.mass[v] / beta;
  s.physical_ldlt.factorize(s.system);
  DSNAKE_ASSERT(s.physical_ldlt.info() == Eigen::Success, "the (mixed) step's system is (quasi-)definite");
  const Eigen::VectorXd& d = s.physical_ldlt.diagonal();
  for (int i = 0; i < int(d.size()); ++i) s.inverse_d[i] = 1.0 / d[i];
  ldlt_solve<D>(s.physical_ldlt.matrixL().nestedExpression(), s.inverse_d, s.order, s.mass.data(), gamma,
                snake.positions(), s.points, out);
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
  if (options_.discretization == InternalDiscretization::kPhysical) return physical_value(snake);
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
    for (int w : ring)
      if (w > v) e += 0.5 * alpha * (q[v] - q[w]).squaredNorm();  // each edge once
    if (!ring.empty()) e += 0.5 * beta * umbrella_laplacian<D>(c, q, v).squaredNorm();
  }
  return e;
}

template <int D>
bool InternalEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  if (options_.discretization == InternalDiscretization::kPhysical) {
    add_physical_residuals(snake, weight, problem);
    return true;
  }
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

// The physical E_int at q with M and K of q (internal.h), written with differences inside each
// element (translation-invariant in floating point): 1/2 alpha sum_e sum_ij K_e,ij (q_i - q_0).(q_j - q_0)
// + 1/2 beta sum_v |(K q)_v|^2 / M_v, (K q)_v = sum_e sum_j K_e,vj (q_j - q_v).
template <int D>
double InternalEnergy<D>::physical_value(const Snake<D>& snake) const {
  const PointList<D>& q = snake.positions();
  const std::vector<int> elements = element_vertices<D>(snake.connectivity());
  std::vector<double> local, mass;
  // M and K q only for the rigidity (the energy trace of a tension-only run, beta = 0,
  // evaluates this at every iteration).
  const bool rigid = options_.beta > 0;
  element_stiffness_and_mass<D>(q, elements, local, mass, rigid);
  PointList<D> kq(rigid ? q.size() : 0, Point<D>::Zero());
  double tension = 0;
  for (size_t e = 0; e < elements.size() / D; ++e) {
    const int* v = elements.data() + e * D;
    const double* k = local.data() + e * D * D;
    for (int i = 0; i < D; ++i)
      for (int j = 0; j < D; ++j) {
        tension += k[D * i + j] * (q[v[i]] - q[v[0]]).dot(q[v[j]] - q[v[0]]);
        if (rigid) kq[v[i]] += k[D * i + j] * (q[v[j]] - q[v[i]]);
      }
  }
  double rigidity = 0;
  if (options_.beta > 0)
    for (size_t v = 0; v < q.size(); ++v) rigidity += kq[v].squaredNorm() / mass[v];
  return 0.5 * options_.alpha * tension + 0.5 * options_.beta * rigidity;
}

// The physical residuals (internal.h), M and K frozen at the snake's positions.
//  alpha, 2D: sqrt(w alpha / (2 l)) (q_1 - q_0) per edge;
//         3D: per triangle, in an orthonormal basis (b_1, b_2) of its plane, the two residuals
//             sqrt(w alpha / (8 A)) sum_i (e_i . b_c) q_i, whose squares sum to
//             1/2 w alpha sum_ij e_i . e_j / (4 A) q_i . q_j (grad phi_i = n x e_i / (2 A));
//  beta: sqrt(w beta / (2 M_v)) (K q)_v per vertex.
template <int D>
void InternalEnergy<D>::add_physical_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  const PointList<D>& q = snake.positions();
  const std::vector<int> elements = element_vertices<D>(snake.connectivity());
  const double alpha = weight * options_.alpha, beta = weight * options_.beta;
  if (alpha > 0) {
    const double floor = element_measure_floor<D>(q, elements);
    for (size_t e = 0; e < elements.size(); e += D) {
      const std::span<const int> v(elements.data() + e, D);
      if constexpr (D == 2) {
        const double coefficients[2] = {-1.0, 1.0};
        const double length = std::max((q[v[1]] - q[v[0]]).norm(), floor);
        problem.add_linear_residual(v, coefficients, std::sqrt(0.5 * alpha / length));
      } else {
        Point<3> edge[3];
        double area = 0;
        triangle_edges(q, v.data(), floor, edge, area);
        int longest = 0;
        for (int i = 1; i < 3; ++i)
          if (edge[i].squaredNorm() > edge[longest].squaredNorm()) longest = i;
        if (!(edge[longest].squaredNorm() > 0)) continue;  // a triangle shrunk to a point: K_T = 0
        const Point<3> b1 = edge[longest].normalized(), other = edge[(longest + 1) % 3];
        const Point<3> b2 = other - other.dot(b1) * b1;
        const double scale = std::sqrt(alpha / (8.0 * area));
        for (const Point<3>& b : {b1, b2.norm() > 0 ? Point<3>(b2.normalized()) : Point<3>(Point<3>::Zero())}) {
          if (b.squaredNorm() == 0) continue;  // collinear: the edges lie along b1
          const double coefficients[3] = {edge[0].dot(b), edge[1].dot(b), edge[2].dot(b)};
          problem.add_linear_residual(v, coefficients, scale);
        }
      }
    }
  }
  if (beta > 0) {
    std::vector<double> mass;
    const SparseMatrix k = stiffness_matrix<D>(snake, elements, mass);
    std::vector<int> vertices;
    std::vector<double> coefficients;
    for (int v = 0; v < snake.num_vertices(); ++v) {  // column v of the symmetric K is row v
      vertices.clear();
      coefficients.clear();
      for (SparseMatrix::InnerIterator it(k, v); it; ++it) {
        vertices.push_back(int(it.row()));
        coefficients.push_back(it.value());
      }
      problem.add_linear_residual(vertices, coefficients, std::sqrt(0.5 * beta / mass[v]));
    }
  }
}

template class InternalEnergy<2>;
template class InternalEnergy<3>;

}  // namespace dsnake
