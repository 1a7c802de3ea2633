// ASAP-MLS deformation energy; see asap_mls.h. Levi & Gotsman, "D-Snake: Image registration by
// as-similar-as-possible template deformation" (IEEE TVCG), §4.1-§4.4, §7 and the Appendix;
// Schaefer et al., "Image deformation using moving least squares" (SIGGRAPH 2006).
#include "energies/asap_mls.h"

#include "energies/block_quadratic.h"
#include "energies/mls_weights.h"
#include "energies/residual_blocks.h"
#include "framework/core/errors.h"

#include "framework/core/vector_clones.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {
Point<2> perp(const Point<2>& a) { return Point<2>(-a[1], a[0]); }  // (x, y)^perp = (-y, x), §4.1
}  // namespace

// Template data of §7, per j and per (j, i) entry of the neighbourhood CSR, plus scratch.
template <int D>
struct AsapMlsEnergy<D>::Data {
  using Matrix = Eigen::Matrix<double, D, D>;
  const Template<D>* tmpl = nullptr;  // the rest shape (the template, or `phase_rest`)
  const Template<D>* source = nullptr;  // the template bound (context.tmpl)
  Template<D> phase_rest;  // rest "phase_start": the template with the phase's start positions
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
  // 3D: the neighbourhoods of vertices 4 g .. 4 g + 3 side by side (group g), for the lane
  // kernels below: row k of group g holds lane l's entry k (or padding past its count: index j,
  // weight 0, which the kernels never add). Per row and lane: i, w_ji and a_fixed.
  struct LaneGroups {
    std::vector<int> first_row, rows;  // per group
    std::vector<int> count;            // per lane (4 per group): its entries
    std::vector<int> index;
    std::vector<double> w, fixed[3];
  } lanes;
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

namespace {

// Four neighbourhoods at once (the energy trace evaluates every D_j at every iteration,
// 96 000 terms on the lung's 310 vertices with N(j) = all, and the approximate step fits as many).
// Each lane does exactly the arithmetic of the scalar loops it stands for, in the same order (the
// compiler fuses no multiply and add: -ffp-contract=off), so every sum has the same bits; a lane
// past its neighbourhood's end keeps its sums (a select, not an added zero).
typedef double Lanes __attribute__((vector_size(32)));
typedef double UnalignedLanes __attribute__((vector_size(32), aligned(8)));  // (typedef: see grid_diffusion_solver.cpp's Vec8)
typedef int64_t LaneMask __attribute__((vector_size(32)));
constexpr int kLanes = 4;

// A group's rows as the kernels read them.
struct LaneRows {
  const int* index;  // rows x 4
  const double *w, *a0, *a1, *a2;
  const int* count;  // 4
  int rows;
};

// (Macros, not functions: a function taking or returning these vectors by value would be
// compiled for the default target, outside the kernels' clones, with another calling convention.)
#define DSNAKE_LANES_LOAD(p) (*reinterpret_cast<const UnalignedLanes*>(p))
#define DSNAKE_LIVE_LANES(count, k) \
  (LaneMask{(k) < (count)[0] ? -1 : 0, (k) < (count)[1] ? -1 : 0, (k) < (count)[2] ? -1 : 0, (k) < (count)[3] ? -1 : 0})
// Coordinate array qc at the four lanes' neighbours i (one load when they are the same vertex).
#define DSNAKE_GATHER(qc, i)                                                                     \
  ((i)[0] == (i)[1] && (i)[1] == (i)[2] && (i)[2] == (i)[3] ? Lanes{} + (qc)[(i)[0]]             \
                                                           : Lanes{(qc)[(i)[0]], (qc)[(i)[1]], (qc)[(i)[2]], (qc)[(i)[3]]})

// fixed_fit's sum for each lane: cross = sum_k w (q_i - q_j) a^T, a = a_fixed. qj: the lanes' own
// positions; cross[3 c + r] (column-major), per lane.
DSNAKE_VECTOR_CLONES
void fixed_cross_lanes(const LaneRows& g, const double* const* q, const Lanes* qj, Lanes* cross) {
  for (int x = 0; x < 9; ++x) cross[x] = Lanes{};
  const bool full = g.count[0] == g.rows && g.count[1] == g.rows && g.count[2] == g.rows && g.count[3] == g.rows;
  for (int k = 0; k < g.rows; ++k) {
    const int* i = g.index + kLanes * k;
    const Lanes w = DSNAKE_LANES_LOAD(g.w + kLanes * k);
    const Lanes a[3] = {DSNAKE_LANES_LOAD(g.a0 + kLanes * k), DSNAKE_LANES_LOAD(g.a1 + kLanes * k), DSNAKE_LANES_LOAD(g.a2 + kLanes * k)};
    Lanes wd[3];
    for (int r = 0; r < 3; ++r) wd[r] = w * (DSNAKE_GATHER(q[r], i) - qj[r]);
    if (full) {
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) cross[3 * c + r] = cross[3 * c + r] + wd[r] * a[c];
    } else {
      const LaneMask live = DSNAKE_LIVE_LANES(g.count, k);
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) cross[3 * c + r] = live ? cross[3 * c + r] + wd[r] * a[c] : cross[3 * c + r];
    }
  }
}

// local_energies' sum for each lane: sum_k w |M a - (q_i - q_j)|^2, a = a_fixed; m[3 c + r]:
// the lanes' M (column-major). (Results through memory: a vector returned by value would change
// the calling convention between the clones.)
DSNAKE_VECTOR_CLONES
void fixed_energy_lanes(const LaneRows& g, const double* const* q, const Lanes* qj, const Lanes* m, double* out) {
  Lanes energy = {};
  for (int k = 0; k < g.rows; ++k) {
    const int* i = g.index + kLanes * k;
    const Lanes w = DSNAKE_LANES_LOAD(g.w + kLanes * k);
    const Lanes a[3] = {DSNAKE_LANES_LOAD(g.a0 + kLanes * k), DSNAKE_LANES_LOAD(g.a1 + kLanes * k), DSNAKE_LANES_LOAD(g.a2 + kLanes * k)};
    // M a in Eigen's order for a fixed 3 x 3 times 3 product (rows 0 and 1 as a packet, row 2
    // alone): ((m0 a0 + m1 a1) + m2 a2) and m0 a0 + (m1 a1 + m2 a2).
    Lanes v[3];
    for (int r = 0; r < 2; ++r)
      v[r] = ((m[r] * a[0] + m[3 + r] * a[1]) + m[6 + r] * a[2]) - (DSNAKE_GATHER(q[r], i) - qj[r]);
    v[2] = (m[2] * a[0] + (m[5] * a[1] + m[8] * a[2])) - (DSNAKE_GATHER(q[2], i) - qj[2]);
    const Lanes term = w * ((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]);
    const LaneMask live = DSNAKE_LIVE_LANES(g.count, k);
    energy = live ? energy + term : energy;
  }
  for (int l = 0; l < kLanes; ++l) out[l] = energy[l];
}

// The approximate step's sums for one vertex j (eq. (6)): centroid = sum_k w q_i and
// cross = sum_k (w q_i) a^T, a = a_free, over its `count` entries (ids, w, a), with the three
// coordinates in the lanes of one vector (the fourth is spare): each sum in k order, as fit()'s
// loop, so the same bits. cross: column-major.
DSNAKE_VECTOR_CLONES
void free_sums(const int* ids, const double* w, const double* a, int count, const double* q, double* centroid_out,
               double* cross_out) {
  Lanes centroid = {}, col[3] = {};
  for (int k = 0; k < count; ++k) {
    const double* qi = q + 3 * ids[k];
    const Lanes wq = w[k] * Lanes{qi[0], qi[1], qi[2], 0.0};
    centroid = centroid + wq;
    for (int c = 0; c < 3; ++c) col[c] = col[c] + wq * a[3 * k + c];
  }
  for (int r = 0; r < 3; ++r) {
    centroid_out[r] = centroid[r];
    for (int c = 0; c < 3; ++c) cross_out[3 * c + r] = col[c][r];
  }
}

}  // namespace

template <int D>
void AsapMlsEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  Data& d = *data_;
  const Template<D>* tmpl = context.tmpl ? context.tmpl : d.source;
  DSNAKE_ASSERT(tmpl != nullptr, "asap_mls is bound to a template");
  if (tmpl != d.source || tmpl->num_vertices() != d.n) {
    try {
      check_template(*tmpl);
    } catch (const OptionError& e) {
      throw_invalid_options(kType, e);
    }
    d.source = tmpl;
    build(*tmpl);
  }
  map_template_vertices(snake, d.n, d.vertex_of_id);
  d.bound_vertices = snake.num_vertices();
  d.bound_version = snake.topology_version();
}

template <int D>
void AsapMlsEnergy<D>::begin_phase(const Snake<D>& snake) {
  Data& d = *data_;
  if (options_.rest != AsapRest::kPhaseStart || d.source == nullptr) return;
  d.phase_rest = *d.source;
  for (int v = 0; v < snake.num_vertices(); ++v)
    if (snake.is_deformation_vertex(v)) d.phase_rest.positions[snake.template_id(v)] = snake.positions()[v];
  build(d.phase_rest);
}

template <int D>
void AsapMlsEnergy<D>::build(const Template<D>& rest) {
  Data& d = *data_;
  const int n = rest.num_vertices();
  const NeighborhoodSpec& spec = options_.neighborhood;
  d.tmpl = &rest;
  d.n = n;
  d.nb = build_neighborhoods<D>(rest, spec);
  const PointList<D>& p = rest.positions;
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
  if constexpr (D == 3) build_lanes();
  d.q.resize(n);
  d.next.resize(n);
  d.before.resize(n);
  d.similarity.resize(n);
}

// The lane groups of Data (3D).
template <int D>
void AsapMlsEnergy<D>::build_lanes() {
  Data& d = *data_;
  auto& L = d.lanes;
  L = {};
  const int groups = (d.n + kLanes - 1) / kLanes;
  int rows = 0;
  for (int g = 0; g < groups; ++g) {
    int most = 0;
    for (int l = 0; l < kLanes; ++l) {
      const int j = g * kLanes + l;
      const int count = j < d.n ? d.nb.offsets[j + 1] - d.nb.offsets[j] : 0;
      L.count.push_back(count);
      most = std::max(most, count);
    }
    L.first_row.push_back(rows);
    L.rows.push_back(most);
    rows += most;
  }
  L.index.assign(size_t(rows) * kLanes, 0);
  L.w.assign(size_t(rows) * kLanes, 0.0);
  for (int c = 0; c < 3; ++c) L.fixed[c].assign(size_t(rows) * kLanes, 0.0);
  for (int g = 0; g < groups; ++g)
    for (int l = 0; l < kLanes; ++l) {
      const int j = std::min(g * kLanes + l, d.n - 1);
      for (int k = 0; k < L.rows[g]; ++k) {
        const size_t at = size_t(L.first_row[g] + k) * kLanes + l;
        if (k >= L.count[size_t(g) * kLanes + l]) {
          L.index[at] = j;  // padding: never added
          continue;
        }
        const int e = d.nb.offsets[j] + k;
        L.index[at] = d.nb.index[e];
        L.w[at] = d.nb.weight[e];
        for (int c = 0; c < 3; ++c) L.fixed[c][at] = d.a_fixed[e][c];
      }
    }
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
      if constexpr (D == 3) {  // the same sums, a vector per entry (free_sums)
        free_sums(ids.data(), w.data(), d.a_free[d.nb.offsets[j]].data(), int(ids.size()), q.data()->data(),
                  centroid.data(), cross.data());
        return centroid + best_similarity<D>(cross, d.spread_free[j]) * d.offset[j];
      }
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
  if constexpr (D == 3) {
    // Four vertices at a time (fixed_cross_lanes, fixed_energy_lanes): the same bits as below.
    std::vector<double> qs[3];
    for (int c = 0; c < 3; ++c) {
      qs[c].resize(d.n);
      for (int j = 0; j < d.n; ++j) qs[c][j] = q[j][c];
    }
    const double* qp[3] = {qs[0].data(), qs[1].data(), qs[2].data()};
    const auto& L = d.lanes;
    const int groups = int(L.rows.size());
#pragma omp parallel for schedule(static) if (d.n >= 256)
    for (int g = 0; g < groups; ++g) {
      const size_t row = size_t(L.first_row[g]) * kLanes;
      const LaneRows rows{L.index.data() + row, L.w.data() + row, L.fixed[0].data() + row, L.fixed[1].data() + row,
                          L.fixed[2].data() + row, L.count.data() + size_t(g) * kLanes, L.rows[g]};
      int j[kLanes];
      for (int l = 0; l < kLanes; ++l) j[l] = std::min(g * kLanes + l, d.n - 1);
      Lanes qj[3];
      for (int c = 0; c < 3; ++c) qj[c] = Lanes{qp[c][j[0]], qp[c][j[1]], qp[c][j[2]], qp[c][j[3]]};
      Lanes cross[9], m[9];
      fixed_cross_lanes(rows, qp, qj, cross);
      for (int l = 0; l < kLanes; ++l) {
        Eigen::Matrix3d c;
        for (int x = 0; x < 9; ++x) c(x % 3, x / 3) = cross[x][l];
        const Eigen::Matrix3d ml = best_similarity<3>(c, d.spread_fixed[j[l]]);
        for (int x = 0; x < 9; ++x) m[x][l] = ml(x % 3, x / 3);
      }
      double e[kLanes];
      fixed_energy_lanes(rows, qp, qj, m, e);
      for (int l = 0; l < kLanes && g * kLanes + l < d.n; ++l) local[g * kLanes + l] = e[l];
    }
    return local;
  }
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
