// ASAP-MLS deformation energy; see asap_mls.h. Levi & Gotsman, "D-Snake: Image registration by
// as-similar-as-possible template deformation" (IEEE TVCG), §4.1-§4.4, §7 and the Appendix;
// Schaefer et al., "Image deformation using moving least squares" (SIGGRAPH 2006).
#include "energies/asap_mls.h"

#include "energies/block_quadratic.h"
#include "energies/mls_weights.h"
#include "energies/residual_blocks.h"
#include "framework/core/errors.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace dsnake {

namespace {
Point<2> perp(const Point<2>& a) { return Point<2>(-a[1], a[0]); }  // (x, y)^perp = (-y, x), §4.1
}  // namespace

// Template data of §7, per j and per (j, i) entry of the neighbourhood CSR, plus scratch.
template <int D>
struct AsapMlsEnergy<D>::Data {
  using Matrix = Eigen::Matrix<double, D, D>;
  const Template<D>* tmpl = nullptr;
  int n = 0;
  MlsNeighborhoods nb;
  PointList<D> a_fixed;     // per entry: p_i - p_j (the constrained fit, T_j(p_j) = q_j)
  PointList<D> a_free;      // per entry: p_i - p*_j (the free fit of eq. (6))
  std::vector<double> spread_fixed, spread_free;  // per j: sum_i w_ij |a|^2
  PointList<D> offset;      // per j: p_j - p*_j
  std::vector<int> reverse_offsets{0}, reverse_entries;  // per k: entries e of the j with k in N(j)
  std::vector<int> entry_owner;                           // per entry: j
  BlockQuadratic<D> quadratic;  // 2D exact: H with E_def = q^T H q
  std::vector<int> vertex_of_id;
  int bound_vertices = -1;      // the snake's vertex count and topology version at the last bind
  uint64_t bound_version = 0;
  PointList<D> q, next, before;
  std::vector<Matrix, Eigen::aligned_allocator<Matrix>> similarity;  // 3D exact: mu_j R_j
};

template <int D>
AsapMlsEnergy<D>::AsapMlsEnergy(const AsapMlsOptions& options)
    : options_(checked(options, kType)), data_(std::make_unique<Data>()) {
  try {
    check_options(options);
  } catch (const OptionError& e) {
    throw_invalid_options(kType, e);
  }
}

template <int D>
void AsapMlsEnergy<D>::check_template(const Template<D>& tmpl) const {
  const NeighborhoodSpec& spec = options_.neighborhood;
  const int n = tmpl.num_vertices();
  if (spec.kind == NeighborhoodKind::kNearest && spec.k > n - 1)
    throw OptionError{"k", "k = " + std::to_string(spec.k) + " exceeds the " + std::to_string(n - 1) +
                               " other template vertices"};
}

template <int D>
AsapMlsEnergy<D>::~AsapMlsEnergy() = default;

// The constrained optimal similarity of D_j (eq. (4) in 2D, Appendix in 3D) from positions by id.
template <int D>
static Eigen::Matrix<double, D, D> fixed_fit(const MlsNeighborhoods& nb, const PointList<D>& a, double spread,
                                             int j, const PointList<D>& q) {
  Eigen::Matrix<double, D, D> cross = Eigen::Matrix<double, D, D>::Zero();
  const auto ids = nb.neighbors(j);
  const auto w = nb.weights(j);
  for (size_t k = 0; k < ids.size(); ++k) cross.noalias() += w[k] * (q[ids[k]] - q[j]) * a[nb.offsets[j] + k].transpose();
  return best_similarity<D>(cross, spread);
}

template <int D>
void AsapMlsEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  Data& d = *data_;
  const Template<D>* tmpl = context.tmpl ? context.tmpl : d.tmpl;
  DSNAKE_ASSERT(tmpl != nullptr, "asap_mls is bound to a template");
  if (tmpl != d.tmpl || tmpl->num_vertices() != d.n) {
    const int n = tmpl->num_vertices();
    const NeighborhoodSpec& spec = options_.neighborhood;
    try {
      check_template(*tmpl);
    } catch (const OptionError& e) {
      throw_invalid_options(kType, e);
    }
    d.tmpl = tmpl;
    d.n = n;
    d.nb = build_neighborhoods<D>(*tmpl, spec);
    const PointList<D>& p = tmpl->positions;
    const size_t entries = d.nb.index.size();
    d.a_fixed.resize(entries);
    d.a_free.resize(entries);
    d.entry_owner.resize(entries);
    d.spread_fixed.assign(n, 0.0);
    d.spread_free.assign(n, 0.0);
    d.offset.assign(n, Point<D>::Zero());
    std::vector<int> count(n + 1, 0);
    for (int j = 0; j < n; ++j) {
      const auto ids = d.nb.neighbors(j);
      const auto w = d.nb.weights(j);
      Point<D> centroid = Point<D>::Zero();
      for (size_t k = 0; k < ids.size(); ++k) centroid += w[k] * p[ids[k]];
      if (ids.empty()) centroid = p[j];
      d.offset[j] = p[j] - centroid;
      for (size_t k = 0; k < ids.size(); ++k) {
        const int e = d.nb.offsets[j] + int(k);
        d.a_fixed[e] = p[ids[k]] - p[j];
        d.a_free[e] = p[ids[k]] - centroid;
        d.spread_fixed[j] += w[k] * d.a_fixed[e].squaredNorm();
        d.spread_free[j] += w[k] * d.a_free[e].squaredNorm();
        d.entry_owner[e] = j;
        ++count[ids[k] + 1];
      }
    }
    // reverse lists: for each k, the entries (j, k) with k in N(j) (3D exact position update)
    for (int k = 0; k < n; ++k) count[k + 1] += count[k];
    d.reverse_offsets = count;
    d.reverse_entries.assign(entries, 0);
    std::vector<int> fill(count.begin(), count.end() - 1);
    for (size_t e = 0; e < entries; ++e) d.reverse_entries[fill[d.nb.index[e]]++] = int(e);
    if (D == 2 && options_.variant == AsapVariant::kExact) build_quadratic();
    d.q.resize(n);
    d.next.resize(n);
    d.before.resize(n);
    d.similarity.resize(n);
  }
  map_template_vertices(snake, d.n, d.vertex_of_id);
  d.bound_vertices = snake.num_vertices();
  d.bound_version = snake.topology_version();
}

template <int D>
void AsapMlsEnergy<D>::build_quadratic() {
  // Only the 2D instantiation uses H; the body is written for D = 2 (see the specialisation).
}

// §4.1: D_j(q) = sum w |u|^2 - (s^2 + t^2) / P with u_l = q_l - q_j, s = sum w a.u, t = sum w a^perp.u,
// so D_j = u^T K u with K_ll' = w_l d_ll' I - w_l w_l' (a_l a_l'^T + a_l^perp a_l'^perp^T) / P, and
// E_def = q^T H q after substituting u_l = q_l - q_j. Coordinate descent on H is eq. (5).
template <>
void AsapMlsEnergy<2>::build_quadratic() {
  Data& d = *data_;
  d.quadratic.reset(d.n);
  for (int j = 0; j < d.n; ++j) {
    const auto ids = d.nb.neighbors(j);
    const auto w = d.nb.weights(j);
    const int m = int(ids.size());
    const double spread = d.spread_fixed[j];
    const bool fit = spread > 1e-300;
    std::vector<Block<2>> row_sum(m, Block<2>::Zero());
    Block<2> total = Block<2>::Zero();
    for (int l = 0; l < m; ++l) {
      const Point<2>& al = d.a_fixed[d.nb.offsets[j] + l];
      for (int k = 0; k < m; ++k) {
        const Point<2>& ak = d.a_fixed[d.nb.offsets[j] + k];
        Block<2> b = (l == k ? w[l] : 0.0) * Block<2>::Identity();
        if (fit) b -= (w[l] * w[k] / spread) * (al * ak.transpose() + perp(al) * perp(ak).transpose());
        d.quadratic.add(ids[l], ids[k], b);
        row_sum[l] += b;
      }
      total += row_sum[l];
    }
    for (int l = 0; l < m; ++l) {  // K symmetric: column sums are the row sums transposed
      d.quadratic.add(ids[l], j, -row_sum[l]);
      d.quadratic.add(j, ids[l], -row_sum[l].transpose());
    }
    d.quadratic.add(j, j, total);
  }
  d.quadratic.finalize();
}

// Removes from the move after - before its least-squares component along the infinitesimal
// similarities at `before` (unit masses): the mean translation, the rotation omega = I^-1 L (L the
// angular momentum sum r x u about the centroid, I the inertia tensor; 2D: omega = L / sum |r|^2)
// and, with `scale`, the dilation sum r.u / sum |r|^2. The three are orthogonal to one another,
// so they are removed one after the other. Serial sums: the same on any thread count.
template <int D>
static void remove_net_motion(const PointList<D>& before, PointList<D>& after, bool scale) {
  const int n = int(before.size());
  if (n == 0) return;
  Point<D> centroid = Point<D>::Zero(), shift = Point<D>::Zero();
  for (int i = 0; i < n; ++i) {
    centroid += before[i];
    shift += after[i] - before[i];
  }
  centroid /= n;
  shift /= n;
  double inertia_trace = 0.0;
  for (int i = 0; i < n; ++i) {
    after[i] -= shift;
    inertia_trace += (before[i] - centroid).squaredNorm();
  }
  if (!(inertia_trace > 1e-300)) return;  // every vertex at one point: no rotation or scaling
  if constexpr (D == 2) {
    double momentum = 0.0;
    for (int i = 0; i < n; ++i) momentum += perp(before[i] - centroid).dot(after[i] - before[i]);
    const double omega = momentum / inertia_trace;
    for (int i = 0; i < n; ++i) after[i] -= omega * perp(before[i] - centroid);
  } else {
    Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d r = before[i] - centroid;
      momentum += r.cross(after[i] - before[i]);
      inertia += r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose();
    }
    // pseudo-inverse: collinear vertices have no inertia about their line (no rotation there)
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
    Eigen::Vector3d inverse = Eigen::Vector3d::Zero();
    for (int a = 0; a < 3; ++a)
      if (eig.eigenvalues()[a] > 1e-12 * inertia_trace) inverse[a] = 1.0 / eig.eigenvalues()[a];
    const Eigen::Vector3d omega = eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose() * momentum;
    for (int i = 0; i < n; ++i) after[i] -= omega.cross(Eigen::Vector3d(before[i] - centroid));
  }
  if (scale) {
    double dilation = 0.0;
    for (int i = 0; i < n; ++i) dilation += (before[i] - centroid).dot(after[i] - before[i]);
    dilation /= inertia_trace;
    for (int i = 0; i < n; ++i) after[i] -= dilation * (before[i] - centroid);
  }
}

// One application of the chosen operator to the positions by id, d.q -> d.q.
template <int D>
void AsapMlsEnergy<D>::step() {
  Data& d = *data_;
  const int n = d.n;
  if (options_.variant == AsapVariant::kApproximate) {
    // eq. (6): q_j <- T^_j(p_j) = q*_j + M^_j (p_j - p*_j), with cross = sum w q_i (p_i - p*)^T.
    // "jacobi": every vertex from the old positions (parallel); "gauss_seidel": one self-energy
    // at a time, in id order, from the newest positions (§4.4), serial.
    auto fit = [&d](int j, const PointList<D>& q) -> Point<D> {
      const auto ids = d.nb.neighbors(j);
      const auto w = d.nb.weights(j);
      if (ids.empty()) return q[j];
      Eigen::Matrix<double, D, D> cross = Eigen::Matrix<double, D, D>::Zero();
      Point<D> centroid = Point<D>::Zero();
      for (size_t k = 0; k < ids.size(); ++k) {
        const Point<D>& qi = q[ids[k]];
        centroid += w[k] * qi;
        cross.noalias() += (w[k] * qi) * d.a_free[d.nb.offsets[j] + k].transpose();
      }
      return centroid + best_similarity<D>(cross, d.spread_free[j]) * d.offset[j];
    };
    if (options_.gauss_seidel()) {
      for (int j = 0; j < n; ++j) d.q[j] = fit(j, d.q);
      return;
    }
#pragma omp parallel for schedule(static) if (n >= 256)
    for (int j = 0; j < n; ++j) d.next[j] = fit(j, d.q);
    std::swap(d.q, d.next);
    return;
  }
  if constexpr (D == 2) {
    if (options_.gauss_seidel()) d.quadratic.gauss_seidel(d.q);
    else { d.quadratic.jacobi(d.q, d.next); std::swap(d.q, d.next); }
  } else {
    // §4.2, phase 1: the optimal mu_j R_j of every D_j at the current positions.
#pragma omp parallel for schedule(static) if (n >= 256)
    for (int j = 0; j < n; ++j) d.similarity[j] = fixed_fit<D>(d.nb, d.a_fixed, d.spread_fixed[j], j, d.q);
    // phase 2: every q_k to the minimiser of E_def with the similarities and the other vertices
    // fixed: the weighted mean of q_i - M_k (p_i - p_k) (its own D_k) and q_j + M_j (p_k - p_j)
    // (the D_j with k in N(j)).
#pragma omp parallel for schedule(static) if (n >= 256)
    for (int k = 0; k < n; ++k) {
      const auto ids = d.nb.neighbors(k);
      const auto w = d.nb.weights(k);
      Point<D> sum = Point<D>::Zero();
      double total = 0.0;
      for (size_t e = 0; e < ids.size(); ++e) {
        sum += w[e] * (d.q[ids[e]] - d.similarity[k] * d.a_fixed[d.nb.offsets[k] + e]);
        total += w[e];
      }
      for (int r = d.reverse_offsets[k]; r < d.reverse_offsets[k + 1]; ++r) {
        const int e = d.reverse_entries[r], j = d.entry_owner[e];
        sum += d.nb.weight[e] * (d.q[j] + d.similarity[j] * d.a_fixed[e]);
        total += d.nb.weight[e];
      }
      d.next[k] = total > 0 ? Point<D>(sum / total) : d.q[k];
    }
    std::swap(d.q, d.next);
  }
}

template <int D>
void AsapMlsEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before propose()");
  DSNAKE_ASSERT(d.bound_vertices == snake.num_vertices() && d.bound_version == snake.topology_version(),
                "bound to the snake's topology (the phase driver rebinds after a remesh)");
  const PointList<D>& q = snake.positions();
  for (int t = 0; t < d.n; ++t) d.q[t] = q[d.vertex_of_id[t]];
  for (int s = 0; s < options_.power; ++s) step();
  const AsapNetMotion net = options_.resolved_net_motion();
  if (net != AsapNetMotion::kKeep) {
    for (int t = 0; t < d.n; ++t) d.before[t] = q[d.vertex_of_id[t]];
    remove_net_motion<D>(d.before, d.q, net == AsapNetMotion::kRemoveSimilarity);
  }
  const double lambda = options_.damping;
  for (int t = 0; t < d.n; ++t) {
    const int v = d.vertex_of_id[t];
    out[v] = lambda == 1.0 ? d.q[t] : Point<D>((1 - lambda) * q[v] + lambda * d.q[t]);
  }
}

template <int D>
std::vector<double> AsapMlsEnergy<D>::local_energies(const Snake<D>& snake) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before value()");
  PointList<D> q(d.n);
  for (int t = 0; t < d.n; ++t) {
    const int v = snake.vertex_of_template_id(t);
    DSNAKE_ASSERT(v >= 0, "every template vertex is on the snake");
    q[t] = snake.positions()[v];
  }
  std::vector<double> local(d.n, 0.0);
#pragma omp parallel for schedule(static) if (d.n >= 256)
  for (int j = 0; j < d.n; ++j) {
    const auto m = fixed_fit<D>(d.nb, d.a_fixed, d.spread_fixed[j], j, q);
    const auto ids = d.nb.neighbors(j);
    const auto w = d.nb.weights(j);
    double e = 0.0;
    for (size_t k = 0; k < ids.size(); ++k)
      e += w[k] * (m * d.a_fixed[d.nb.offsets[j] + k] - (q[ids[k]] - q[j])).squaredNorm();
    local[j] = e;
  }
  return local;
}

// Summed serially over j, so the value does not depend on the thread count.
template <int D>
double AsapMlsEnergy<D>::value(const Snake<D>& snake) const {
  double e = 0.0;
  for (double x : local_energies(snake)) e += x;
  return e;
}

template <int D>
bool AsapMlsEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before add_residuals()");
  const double root = std::sqrt(weight);
  for (int j = 0; j < d.n; ++j) {
    const auto ids = d.nb.neighbors(j);
    if (ids.empty()) continue;
    // §4: r_i = sqrt(w_ij) (T_j(p_i) - q_i) with T_j(p) = q_j + e^sigma_j R_j (p - p_j) (the
    // infinite w_jj of eq. (2) pins T_j(p_j) = q_j), T_j an auxiliary block started at its best fit.
    const int centre = snake.vertex_of_template_id(j);
    std::vector<int> others;
    std::vector<double> scales;
    Eigen::Matrix<double, D, D> cross = Eigen::Matrix<double, D, D>::Zero();
    const PointList<D> a(d.a_fixed.begin() + d.nb.offsets[j], d.a_fixed.begin() + d.nb.offsets[j + 1]);
    const auto w = d.nb.weights(j);
    for (int k = 0; k < int(ids.size()); ++k) {
      others.push_back(snake.vertex_of_template_id(ids[k]));
      scales.push_back(root * std::sqrt(w[k]));
      cross.noalias() += w[k] * (snake.positions()[others.back()] - snake.positions()[centre]) * a[k].transpose();
    }
    add_transform_residuals<D>(problem, centre, others, a, scales, true, best_similarity<D>(cross, d.spread_fixed[j]));
  }
  return true;
}

template class AsapMlsEnergy<2>;
template class AsapMlsEnergy<3>;

}  // namespace dsnake
