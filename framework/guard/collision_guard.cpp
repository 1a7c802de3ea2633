#include "framework/guard/collision_guard.h"

#include "framework/core/errors.h"
#include "framework/geometry/predicates.h"
#include "framework/geometry/triangle_pairs.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <type_traits>

namespace dsnake {

namespace {

template <int D>
struct Box {
  Point<D> lo, hi;
};

// A facet's corners at one set of positions and their bounding box. The guard gathers them once
// per round (a facet is in about ten pairs); facets_conflict gathers them per call.
struct Corners3 {
  std::array<Point<3>, 3> x;
  Point<3> lo, hi;
};

Corners3 corners(const PointList<3>& x, const Facet<3>& f) {
  Corners3 c{{x[f[0]], x[f[1]], x[f[2]]}, {}, {}};
  c.lo = c.x[0].cwiseMin(c.x[1]).cwiseMin(c.x[2]);
  c.hi = c.x[0].cwiseMax(c.x[1]).cwiseMax(c.x[2]);
  return c;
}

// Whether facets a and b (corners ca, cb) conflict: the remeshing stages' pair tests, in 3D.
bool facets_conflict(const Facet<3>& a, const Corners3& ca, const Facet<3>& b, const Corners3& cb) {
  return pair_conflicts(a, ca.x, ca.lo, ca.hi, b, cb.x, cb.lo, cb.hi);
}
bool facets_conflict(const PointList<3>& x, const Facet<3>& a, const Facet<3>& b) {
  return facets_conflict(a, corners(x, a), b, corners(x, b));
}

// 2D: segments that share no vertex must not touch (neighbours along the polygon are free).
bool facets_conflict(const PointList<2>& x, const Facet<2>& a, const Facet<2>& b) {
  if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) return false;
  return segments_intersect(x[a[0]], x[a[1]], x[b[0]], x[b[1]]);
}

template <int D>
void list_facets(const Snake<D>& snake, std::vector<Facet<D>>& out) {
  out.clear();
  if constexpr (D == 2) {
    const int n = snake.num_vertices();
    for (int i = 0; i < n && n >= 3; ++i) out.push_back({i, (i + 1) % n});
  } else {
    out.assign(snake.connectivity().triangles().begin(), snake.connectivity().triangles().end());
  }
}

// The box of facet f over its corners at q and at p (every position on the way back from p to
// q lies in it), grown by a relative 1e-9 so that touching boxes overlap.
template <int D>
Box<D> swept_box(const PointList<D>& q, const PointList<D>& p, const Facet<D>& f) {
  Box<D> b{q[f[0]].cwiseMin(p[f[0]]), q[f[0]].cwiseMax(p[f[0]])};
  for (int k = 1; k < D; ++k) {
    b.lo = b.lo.cwiseMin(q[f[k]]).cwiseMin(p[f[k]]);
    b.hi = b.hi.cwiseMax(q[f[k]]).cwiseMax(p[f[k]]);
  }
  const double grow = 1e-9 * (1 + (b.hi - b.lo).maxCoeff() + b.hi.cwiseAbs().maxCoeff());
  b.lo.array() -= grow;
  b.hi.array() += grow;
  return b;
}

template <int D>
bool overlap(const Box<D>& a, const Box<D>& b) {
  return (a.lo.array() <= b.hi.array()).all() && (b.lo.array() <= a.hi.array()).all();
}

// The broad phase: every pair of facets (i < j) whose swept boxes overlap and one of which has a
// moved corner, into `pairs` (in cell order). A uniform grid of cells about one box wide (at
// most ~8 cells per facet), each facet listed in the cells its box covers; a pair is taken in
// the cell of its overlap's low corner only.
template <int D>
class SweptGrid {
 public:
  SweptGrid(const std::vector<Box<D>>& boxes) : boxes_(boxes) {
    const int n = static_cast<int>(boxes.size());
    Point<D> lo = Point<D>::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    double extent = 0;
    for (const Box<D>& b : boxes) {
      lo = lo.cwiseMin(b.lo), hi = hi.cwiseMax(b.hi);
      extent += (b.hi - b.lo).maxCoeff();
    }
    origin_ = lo;
    cell_ = std::max(extent / std::max(n, 1), 1e-12 * (1 + (hi - lo).maxCoeff()));
    auto count = [&](int k) { return std::floor((hi[k] - lo[k]) / cell_) + 1; };
    auto total = [&] {
      double c = 1;
      for (int k = 0; k < D; ++k) c *= count(k);
      return c;
    };
    while (total() > 8.0 * n + 64) cell_ *= 1.25;
    for (int k = 0; k < D; ++k) dims_[k] = static_cast<int>(count(k));
    fill();
  }

  void pairs(const std::vector<uint8_t>& moved_facet, std::vector<std::array<int, 2>>& out) const;

 private:
  int cell_of(double x, int k) const {
    const double c = std::floor((x - origin_[k]) / cell_);
    return static_cast<int>(std::clamp(c, 0.0, dims_[k] - 1.0));
  }
  std::array<int, 2 * D> range(int f) const {
    std::array<int, 2 * D> r;
    for (int k = 0; k < D; ++k) r[k] = cell_of(boxes_[f].lo[k], k), r[k + D] = cell_of(boxes_[f].hi[k], k);
    return r;
  }
  template <class F>
  void for_cells(const std::array<int, 2 * D>& r, F&& f) const {
    std::array<int, D> c;
    for (int k = 0; k < D; ++k) c[k] = r[k];
    while (true) {
      int64_t index = 0;
      for (int k = D - 1; k >= 0; --k) index = index * dims_[k] + c[k];
      f(index);
      int k = 0;
      while (k < D && ++c[k] > r[k + D]) c[k] = r[k], ++k;
      if (k == D) return;
    }
  }
  void fill() {
    int64_t cells = 1;
    for (int k = 0; k < D; ++k) cells *= dims_[k];
    start_.assign(cells + 1, 0);
    const int n = static_cast<int>(boxes_.size());
    first_.resize(n);
    for (int f = 0; f < n; ++f) {
      const auto r = range(f);
      for (int k = 0; k < D; ++k) first_[f][k] = r[k];
      for_cells(r, [&](int64_t c) { ++start_[c + 1]; });
    }
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    std::vector<int64_t> at(start_.begin(), start_.end() - 1);
    entries_.resize(start_.back());
    for (int f = 0; f < n; ++f) for_cells(range(f), [&](int64_t c) { entries_[at[c]++] = f; });
  }
  const std::vector<Box<D>>& boxes_;
  Point<D> origin_;
  double cell_ = 1;
  std::array<int, D> dims_;
  std::vector<int64_t> start_;
  std::vector<int> entries_;
  std::vector<std::array<int, D>> first_;  // per facet: its first cell on each axis
};

// Per cell, its entries' facet ids, first cells and boxes are gathered once into a local list
// (k gathers instead of k^2 scattered loads), and the ownership test, on integers, runs before
// the box test: a pair met in several cells is owned by one of them (the cell of its overlap's
// low corner: the cell map is monotone, so that corner's cell is the larger of their first
// cells on each axis), so most meetings end there.
template <int D>
void SweptGrid<D>::pairs(const std::vector<uint8_t>& moved, std::vector<std::array<int, 2>>& out) const {
  const int64_t cells = static_cast<int64_t>(start_.size()) - 1;
  const int threads = omp_get_max_threads();
  std::vector<std::vector<std::array<int, 2>>> found(threads);
  struct Entry {
    int id;
    bool moved;
    std::array<int, D> first;
    Box<D> box;
  };
#pragma omp parallel num_threads(threads) if (cells >= 4096)
  {
    auto& mine = found[omp_get_thread_num()];
    std::vector<Entry> local;
#pragma omp for schedule(static)
    for (int64_t c = 0; c < cells; ++c) {
      if (start_[c + 1] - start_[c] < 2) continue;
      std::array<int, D> cell;
      int64_t rest = c;
      for (int k = 0; k < D; ++k) cell[k] = static_cast<int>(rest % dims_[k]), rest /= dims_[k];
      local.clear();
      for (int64_t i = start_[c]; i < start_[c + 1]; ++i) {
        const int f = entries_[i];
        local.push_back({f, moved[f] != 0, first_[f], boxes_[f]});
      }
      const int k = static_cast<int>(local.size());
      for (int i = 0; i < k; ++i)
        for (int j = i + 1; j < k; ++j) {
          const Entry& x = local[i];
          const Entry& y = local[j];
          if (!(x.moved | y.moved)) continue;
          bool owned = true;
          for (int a = 0; a < D; ++a) owned &= std::max(x.first[a], y.first[a]) == cell[a];
          if (owned && overlap(x.box, y.box)) mine.push_back({std::min(x.id, y.id), std::max(x.id, y.id)});
        }
    }
  }
  out.clear();
  for (const auto& f : found) out.insert(out.end(), f.begin(), f.end());
}

// Whether the kept pairs cover this iteration: the same facets, and every vertex at q(t) and at
// the proposed q(t+1) within its allowed box (the later rounds' positions lie between the two,
// so within it too).
template <int D, class Cache>
bool covers(const Cache& cache, const std::vector<Facet<D>>& facets, const PointList<D>& q, const PointList<D>& p) {
  if (facets != cache.facets || cache.allowed_lo.size() != p.size()) return false;
  for (size_t v = 0; v < p.size(); ++v) {
    const Point<D> lo = q[v].cwiseMin(p[v]), hi = q[v].cwiseMax(p[v]);
    if ((lo.array() < cache.allowed_lo[v].array()).any() || (hi.array() > cache.allowed_hi[v].array()).any())
      return false;
  }
  return true;
}

// 3D: the certificates of the kept pairs that share one vertex (triangle_pairs.h,
// shared_vertex_radius) or one edge (shared_edge_radius; cache.radius is sized by the build), at
// positions x, which become the reference that the vertices' drift is measured from.
template <int D, class Cache>
void certify(Cache& cache, const PointList<D>& x) {
  cache.expired = 0, cache.certified = 0;
  if constexpr (D == 3) {
    cache.reference = x;
    const int64_t m = static_cast<int64_t>(cache.adjacent.size());
#pragma omp parallel for schedule(static) if (m >= 4096)
    for (int64_t k = 0; k < m; ++k) {
      const int64_t i = cache.adjacent[k];
      const auto& fa = cache.facets[cache.pairs[i][0]];
      const auto& fb = cache.facets[cache.pairs[i][1]];
      const std::array<Point<3>, 3> pa = {x[fa[0]], x[fa[1]], x[fa[2]]}, pb = {x[fb[0]], x[fb[1]], x[fb[2]]};
      cache.radius[i] = shared_corners(fa, fb) == 1 ? shared_vertex_radius(fa, pa, fb, pb)
                                                                   : shared_edge_radius(fa, pa, fb, pb);
    }
    for (int64_t k = 0; k < m; ++k) cache.certified += cache.radius[cache.adjacent[k]] > 0;
    // The index of the certificates by facet (PairCache).
    const int64_t kept = static_cast<int64_t>(cache.pairs.size());
    const int nf = static_cast<int>(cache.facets.size());
    cache.uncertified.clear();
    cache.facet_radius.assign(nf, std::numeric_limits<double>::infinity());
    cache.certified_start.assign(nf + 1, 0);
    for (int64_t i = 0; i < kept; ++i) {
      if (!(cache.radius[i] > 0)) {
        cache.uncertified.push_back(i);
        continue;
      }
      for (int f : cache.pairs[i]) {
        cache.facet_radius[f] = std::min(cache.facet_radius[f], cache.radius[i]);
        ++cache.certified_start[f + 1];
      }
    }
    for (int f = 0; f < nf; ++f) cache.certified_start[f + 1] += cache.certified_start[f];
    cache.certified_of.resize(cache.certified_start[nf]);
    std::vector<int64_t> at(cache.certified_start.begin(), cache.certified_start.end() - 1);
    for (int64_t i = 0; i < kept; ++i)
      if (cache.radius[i] > 0)
        for (int f : cache.pairs[i]) cache.certified_of[at[f]++] = i;
  }
}

// A broad phase over this iteration's swept boxes widened by a margin, a quarter of their mean
// extent (the pairs then grow by about half, and the list lasts while the vertices move less
// than that), keeping every pair whose widened boxes overlap. Each vertex may then range over
// the box of its positions at q(t) and q(t+1) widened by the margin: a facet's later swept box
// lies in its widened box.
template <int D, class Cache>
void rebuild(Cache& cache, const std::vector<Facet<D>>& facets, const PointList<D>& q, const PointList<D>& p,
             std::vector<Box<D>> boxes) {
  ++cache.builds;
  cache.facets = facets;
  const int nf = static_cast<int>(facets.size());
  double extent = 0;
  for (const Box<D>& b : boxes) extent += (b.hi - b.lo).maxCoeff();
  const double margin = nf > 0 ? 0.25 * extent / nf : 0.0;
  cache.allowed_lo.resize(q.size());
  cache.allowed_hi.resize(q.size());
  for (size_t v = 0; v < q.size(); ++v) {
    cache.allowed_lo[v] = q[v].cwiseMin(p[v]).array() - margin;
    cache.allowed_hi[v] = q[v].cwiseMax(p[v]).array() + margin;
  }
  for (Box<D>& b : boxes) {
    // swept_box grows a box by a relative 1e-9 of its extent and magnitude: a box of positions
    // within the margin grows by at most this much more.
    const double slack = 1e-8 * (1 + (b.hi - b.lo).maxCoeff() + b.hi.cwiseAbs().maxCoeff() + 3 * margin);
    b.lo.array() -= margin + slack;
    b.hi.array() += margin + slack;
  }
  SweptGrid<D>(boxes).pairs(std::vector<uint8_t>(nf, 1), cache.pairs);
  // By facet: each step's box tests and pair tests then read the facets' data in order (the
  // order of the pairs does not change what the guard does: every hit is collected, and the
  // vertices to step back are sorted).
  // A counting sort on the first facet, then each facet's few pairs by the second (a comparison
  // sort of the whole list costs more than it saves).
  std::vector<int> start(nf + 1, 0);
  for (const auto& pair : cache.pairs) ++start[pair[0] + 1];
  for (int f = 0; f < nf; ++f) start[f + 1] += start[f];
  std::vector<std::array<int, 2>> sorted(cache.pairs.size());
  for (const auto& pair : cache.pairs) sorted[start[pair[0]]++] = pair;
  for (int f = 0, begin = 0; f < nf; begin = start[f++])  // start[f]: now the end of f's pairs
    std::sort(sorted.begin() + begin, sorted.begin() + start[f]);
  cache.pairs.swap(sorted);
  // 3D: the pairs that share one vertex or one edge, the ones with certificates.
  cache.adjacent.clear();
  cache.radius.assign(D == 3 ? cache.pairs.size() : 0, 0.0);
  if constexpr (D == 3) {
    for (size_t i = 0; i < cache.pairs.size(); ++i) {
      const int shared = shared_corners(facets[cache.pairs[i][0]], facets[cache.pairs[i][1]]);
      if (shared == 1 || shared == 2) cache.adjacent.push_back(static_cast<int64_t>(i));
    }
  }
  certify<D>(cache, q);
}

}  // namespace

template <int D>
CollisionGuard<D>::CollisionGuard(const CollisionGuardOptions& options) : options_(options) {
  DSNAKE_ASSERT(options.halvings >= 0, "halvings >= 0");
}

namespace {

// 3D: how far each vertex is from the certificates' reference, at q(t) and at q(t+1) (the later
// rounds' positions lie between the two, so no farther), and per facet the farthest of its
// vertices.
template <int D, class Cache>
void measure_drift(const Cache& cache, const std::vector<std::array<int, D>>& facets, const PointList<D>& q,
                   const PointList<D>& p, std::vector<double>& vertex_drift, std::vector<double>& drift) {
  const int n = static_cast<int>(q.size()), nf = static_cast<int>(facets.size());
  vertex_drift.resize(n);
  drift.resize(nf);
#pragma omp parallel if (nf >= 8192)
  {
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v)
      vertex_drift[v] = std::sqrt(
          std::max((q[v] - cache.reference[v]).squaredNorm(), (p[v] - cache.reference[v]).squaredNorm()));
#pragma omp for schedule(static)
    for (int f = 0; f < nf; ++f) {
      double d = 0;
      for (int v : facets[f]) d = std::max(d, vertex_drift[v]);
      drift[f] = d;
    }
  }
}

// The kept pairs to test, into `pairs`: filtered in contiguous chunks (one per thread), joined in
// chunk order. A pair is due a test if one of its facets changed, it has no certificate or its
// facets drifted past it, and its swept boxes overlap. 3D with certificates (`certified`): the
// uncertified pairs, then the certified pairs of the facets whose drift reached their smallest
// certificate (a pair whose facets both stay below theirs stays below its own), each pair
// once (under the first such facet); the same pairs as filtering every kept one
// (`certificate_index` false), in another order, which changes nothing (every hit is collected
// and the vertices to step back sorted). Returns how many certified pairs were due a test.
template <int D, class Cache>
int64_t due_pairs(const Cache& cache, const std::vector<uint8_t>& changed, const std::vector<double>& drift,
                  const std::vector<Box<D>>& boxes, bool certified, bool certificate_index,
                  std::vector<std::array<int, 2>>& pairs) {
  const int nf = static_cast<int>(boxes.size());
  const int64_t kept = static_cast<int64_t>(cache.pairs.size());
  const int chunks = kept >= 32768 ? omp_get_max_threads() : 1;
  std::vector<std::vector<std::array<int, 2>>> chunk_pairs(chunks);
  int64_t expired = 0;
  auto filter = [&](int64_t i, std::vector<std::array<int, 2>>& out, int64_t& expired_here) {
    const auto& pair = cache.pairs[i];
    if (!(changed[pair[0]] | changed[pair[1]])) return;
    if (certified && cache.radius[i] > 0) {
      if (std::max(drift[pair[0]], drift[pair[1]]) < cache.radius[i]) return;
      ++expired_here;
    }
    if (overlap(boxes[pair[0]], boxes[pair[1]])) out.push_back(pair);
  };
  if (certified && certificate_index) {
    const int64_t plain = static_cast<int64_t>(cache.uncertified.size());
    auto hot = [&](int f) { return !(drift[f] < cache.facet_radius[f]); };
#pragma omp parallel for schedule(static) num_threads(chunks) reduction(+ : expired) if (chunks > 1)
    for (int c = 0; c < chunks; ++c) {
      std::vector<std::array<int, 2>>& out = chunk_pairs[c];
      for (int64_t k = plain * c / chunks, end = plain * (c + 1) / chunks; k < end; ++k)
        filter(cache.uncertified[k], out, expired);
      for (int f = int(int64_t(nf) * c / chunks), f_end = int(int64_t(nf) * (c + 1) / chunks); f < f_end; ++f) {
        if (!hot(f)) continue;
        for (int64_t k = cache.certified_start[f]; k < cache.certified_start[f + 1]; ++k) {
          const int64_t i = cache.certified_of[k];
          const int other = cache.pairs[i][0] == f ? cache.pairs[i][1] : cache.pairs[i][0];
          if (other < f && hot(other)) continue;  // taken under `other`
          filter(i, out, expired);
        }
      }
    }
  } else {
#pragma omp parallel for schedule(static) num_threads(chunks) reduction(+ : expired) if (chunks > 1)
    for (int c = 0; c < chunks; ++c)
      for (int64_t i = kept * c / chunks, end = kept * (c + 1) / chunks; i < end; ++i) filter(i, chunk_pairs[c], expired);
  }
  pairs.clear();
  for (const auto& c : chunk_pairs) pairs.insert(pairs.end(), c.begin(), c.end());
  return expired;
}

// Rounds: test the pairs with a facet changed since the last round (first: with a moved
// corner), at the proposed positions p; every vertex of a newly conflicting pair that moved and
// can still step back does so (level k: 2^-k of its move; past `halvings`: none of it), until
// no new conflict is left. `changed` (per facet) and `moved` (per vertex) as the guard set them;
// level[v]: the steps back of v. Returns the exact tests made.
template <int D>
int64_t step_back_rounds(const PointList<D>& q, PointList<D>& p, const std::vector<std::array<int, D>>& facets,
                         const std::vector<std::array<int, 2>>& pairs, std::vector<uint8_t>& changed,
                         std::vector<uint8_t>& moved, std::vector<int>& level, int halvings) {
  const int n = static_cast<int>(q.size()), nf = static_cast<int>(facets.size());
  const PointList<D> wanted = p;  // the proposed positions before any step back
  level.assign(n, 0);
  std::vector<uint8_t> hit(pairs.size());
  std::vector<int> step_back;
  // 3D: the facets' corners at p, all of them before the first round, then those with a corner
  // stepped back (the others' corners have not moved since).
  std::vector<std::conditional_t<D == 3, Corners3, char>> at_p(D == 3 ? nf : 0);
  bool first_round = true;
  int64_t checks = 0;
  while (true) {
    const int64_t m = static_cast<int64_t>(pairs.size());
    int64_t tests = 0;
    if constexpr (D == 3) {
#pragma omp parallel for schedule(static) if (nf >= 8192)
      for (int f = 0; f < nf; ++f)
        if (first_round || changed[f]) at_p[f] = corners(p, facets[f]);
    }
    first_round = false;
#pragma omp parallel for schedule(static) reduction(+ : tests) if (m >= 4096)
    for (int64_t i = 0; i < m; ++i) {
      const auto [a, b] = pairs[i];
      hit[i] = 0;
      if (!(changed[a] | changed[b])) continue;
      ++tests;
      if constexpr (D == 3) {
        hit[i] = facets_conflict(facets[a], at_p[a], facets[b], at_p[b]) && !facets_conflict(q, facets[a], facets[b]);
      } else {
        hit[i] = facets_conflict(p, facets[a], facets[b]) && !facets_conflict(q, facets[a], facets[b]);
      }
    }
    checks += tests;
    step_back.clear();
    for (int64_t i = 0; i < m; ++i) {
      if (!hit[i]) continue;
      for (int f : pairs[i])
        for (int v : facets[f])
          if (moved[v] && level[v] <= halvings) step_back.push_back(v);
    }
    if (step_back.empty()) break;
    std::sort(step_back.begin(), step_back.end());
    step_back.erase(std::unique(step_back.begin(), step_back.end()), step_back.end());
    for (int v : step_back) {
      const int k = ++level[v];
      p[v] = k > halvings ? q[v] : Point<D>(q[v] + std::ldexp(1.0, -k) * (wanted[v] - q[v]));
      moved[v] = 2;  // stepped back in this round
    }
    for (int f = 0; f < nf; ++f) {
      changed[f] = 0;
      for (int v : facets[f]) changed[f] |= moved[v] == 2;
    }
    for (int v : step_back) moved[v] = p[v] != q[v];
  }
  return checks;
}

}  // namespace

// The swept boxes of the facets, the kept pairs (rebuilt or re-certified when due), the drift
// against the certificates, the pairs due a test, then the rounds of steps back.
template <int D>
MoveGuardReport CollisionGuard<D>::guard(const Snake<D>& snake, PointList<D>& p) {
  MoveGuardReport report;
  const PointList<D>& q = snake.positions();
  const int n = snake.num_vertices();
  moved_.assign(n, 0);
  bool any = false;
  for (int v = 0; v < n; ++v) any |= (moved_[v] = p[v] != q[v]) != 0;
  if (!any) return report;
  list_facets<D>(snake, facets_);
  const int nf = static_cast<int>(facets_.size());
  std::vector<Box<D>> boxes(nf);
  changed_.assign(nf, 0);
  for (int f = 0; f < nf; ++f) {
    boxes[f] = swept_box<D>(q, p, facets_[f]);
    for (int v : facets_[f]) changed_[f] |= moved_[v];
  }
  // The pairs whose swept boxes overlap, out of the kept list (rebuilt if it no longer covers
  // them): the same set as a broad phase over the swept boxes themselves.
  if (!covers<D>(cache_, facets_, q, p)) {
    rebuild<D>(cache_, facets_, q, p, boxes);
  } else if (cache_.expired > cache_.certified) {
    // The exact tests of certified pairs whose certificates ran out have cost, since these
    // certificates were made, about as much as making them again: renew them (rent or buy).
    certify<D>(cache_, q);
  }
  // 3D: a pair with a certificate larger than both of its facets' drifts cannot conflict and is
  // not tested.
  const bool certified = D == 3 && cache_.certified > 0;
  if (certified) measure_drift<D>(cache_, facets_, q, p, vertex_drift_, drift_);
  cache_.expired += due_pairs<D>(cache_, changed_, drift_, boxes, certified, certificate_index_, pairs_);
  report.checks += step_back_rounds<D>(q, p, facets_, pairs_, changed_, moved_, level_, options_.halvings);
  for (int v = 0; v < n; ++v) {
    if (level_[v] > options_.halvings) ++report.refused;
    else if (level_[v] > 0) ++report.shortened;
  }
  return report;
}

template class CollisionGuard<2>;
template class CollisionGuard<3>;

}  // namespace dsnake
