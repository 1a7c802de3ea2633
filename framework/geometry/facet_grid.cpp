// The uniform grid and tree over a surface's facets; see facet_grid.h.
#include "framework/geometry/facet_grid.h"

#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>
#include <cmath>
#include <limits>

namespace dsnake {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
// Rings of cells a single-point query walks before the facet tree takes over (FacetGrid::distance).
constexpr int kWalkRings = 2;
// A batch whose candidate box spans more cells than this many per point is queried point by
// point (FacetGrid::batch_distances): gathering would cost more than the tree queries.
constexpr int64_t kGatherCellsPerPoint = 64;

// Squared distance from p to the box [lo, hi] (0 inside).
template <int D>
inline double box_distance2(const Point<D>& p, const Point<D>& lo, const Point<D>& hi) {
  double d2 = 0;
  for (int a = 0; a < D; ++a) {
    const double e = std::max(lo[a] - p[a], p[a] - hi[a]);
    if (e > 0) d2 += e * e;
  }
  return d2;
}

// Squared distance from p to the segment from a along e (inv_len2 = 1 / |e|^2, 0 if e = 0).
template <int D>
inline double prepared_segment_distance2(const Point<D>& p, const Point<D>& a, const Point<D>& e,
                                         double inv_len2) {
  const Point<D> w = p - a;
  const double t = std::clamp(w.dot(e) * inv_len2, 0.0, 1.0);
  return (w - t * e).squaredNorm();
}

// Squared distance from p to a segment (D = 2) or triangle (D = 3). A triangle's nearest point
// is inside when p is on the inner side of all three edges (seen along n), else on an edge
// that p lies beyond (the triangle is convex).
template <int D>
inline double prepared_distance2(const Point<D>& p, const PreparedFacet<D>& f) {
  if constexpr (D == 2) {
    return prepared_segment_distance2<2>(p, f.v[0], f.e[0], f.inv_len2[0]);
  } else {
    double d2 = std::numeric_limits<double>::infinity();
    const double s0 = f.m[0].dot(p - f.v[0]), s1 = f.m[1].dot(p - f.v[1]), s2 = f.m[2].dot(p - f.v[2]);
    if (f.inv_nn > 0 && s0 >= 0 && s1 >= 0 && s2 >= 0) {
      const double h = f.n.dot(p - f.v[0]);
      return h * h * f.inv_nn;
    }
    const bool degenerate = !(f.inv_nn > 0);  // then test every edge
    if (degenerate || s0 < 0) d2 = prepared_segment_distance2<3>(p, f.v[0], f.e[0], f.inv_len2[0]);
    if (degenerate || s1 < 0) d2 = std::min(d2, prepared_segment_distance2<3>(p, f.v[1], f.e[1], f.inv_len2[1]));
    if (degenerate || s2 < 0) d2 = std::min(d2, prepared_segment_distance2<3>(p, f.v[2], f.e[2], f.inv_len2[2]));
    return d2;
  }
}

// Calls f(cell) for each cell of the box of cells [c0, c1].
template <int D, class F>
void for_each_cell_in(const GridIndex<D>& c0, const GridIndex<D>& c1, F&& f) {
  GridIndex<D> c = c0;
  if constexpr (D == 2) {
    for (c[1] = c0[1]; c[1] <= c1[1]; ++c[1])
      for (c[0] = c0[0]; c[0] <= c1[0]; ++c[0]) f(c);
  } else {
    for (c[2] = c0[2]; c[2] <= c1[2]; ++c[2])
      for (c[1] = c0[1]; c[1] <= c1[1]; ++c[1])
        for (c[0] = c0[0]; c[0] <= c1[0]; ++c[0]) f(c);
  }
}

// Calls f(cell) for each cell at Chebyshev distance exactly r from c, clipped to [lo, hi].
template <int D, class F>
void for_each_shell_cell(const GridIndex<D>& c, int r, const GridIndex<D>& lo, const GridIndex<D>& hi, F&& f) {
  auto clip_lo = [&](int a) { return std::max(lo[a], c[a] - r); };
  auto clip_hi = [&](int a) { return std::min(hi[a], c[a] + r); };
  // Along x: the whole clipped range on the shell's caps, else only its two ends.
  auto row = [&](GridIndex<D> cell, bool cap) {
    if (cap) {
      for (cell[0] = clip_lo(0); cell[0] <= clip_hi(0); ++cell[0]) f(cell);
      return;
    }
    if (c[0] - r >= lo[0]) { cell[0] = c[0] - r; f(cell); }
    if (r > 0 && c[0] + r <= hi[0]) { cell[0] = c[0] + r; f(cell); }
  };
  GridIndex<D> cell = c;
  if constexpr (D == 2) {
    for (cell[1] = clip_lo(1); cell[1] <= clip_hi(1); ++cell[1]) row(cell, std::abs(cell[1] - c[1]) == r);
  } else {
    for (cell[2] = clip_lo(2); cell[2] <= clip_hi(2); ++cell[2])
      for (cell[1] = clip_lo(1); cell[1] <= clip_hi(1); ++cell[1])
        row(cell, std::abs(cell[2] - c[2]) == r || std::abs(cell[1] - c[1]) == r);
  }
}

}  // namespace

template <int D>
FacetGrid<D>::FacetGrid(const FacetSurface<D>& surface) {
  const int n = static_cast<int>(surface.facets.size());
  prepared_.resize(n);
  box_lo_.resize(n);
  box_hi_.resize(n);
  Point<D> lo = Point<D>::Constant(kInfinity), hi = Point<D>::Constant(-kInfinity);
  double mean_extent = 0;
  for (int f = 0; f < n; ++f) {
    for (int k = 0; k < D; ++k) {
      const int v = surface.facets[f][k];
      DSNAKE_ASSERT(v >= 0 && v < int(surface.vertices.size()), "facet vertex in range");
      prepared_[f].v[k] = surface.vertices[v];
    }
    PreparedFacet<D>& pf = prepared_[f];
    box_lo_[f] = box_hi_[f] = pf.v[0];
    for (int k = 1; k < D; ++k) {
      box_lo_[f] = box_lo_[f].cwiseMin(pf.v[k]);
      box_hi_[f] = box_hi_[f].cwiseMax(pf.v[k]);
    }
    for (int k = 0; k < D; ++k) {
      pf.e[k] = pf.v[(k + 1) % D] - pf.v[k];
      const double len2 = pf.e[k].squaredNorm();
      pf.inv_len2[k] = len2 > 0 ? 1.0 / len2 : 0.0;
    }
    if constexpr (D == 3) {
      pf.n = pf.e[0].cross(pf.v[2] - pf.v[0]);
      const double nn = pf.n.squaredNorm();
      pf.inv_nn = nn > 0 ? 1.0 / nn : 0.0;
      for (int k = 0; k < 3; ++k) pf.m[k] = pf.n.cross(pf.e[k]);
    }
    lo = lo.cwiseMin(box_lo_[f]);
    hi = hi.cwiseMax(box_hi_[f]);
    mean_extent += (box_hi_[f] - box_lo_[f]).maxCoeff() / n;
  }
  if (n == 0) {
    offsets_.assign(2, 0);
    return;
  }
  DSNAKE_ASSERT(lo.allFinite() && hi.allFinite(), "facet positions are finite");
  const Point<D> extent = hi - lo;
  if (!(mean_extent > 0)) mean_extent = std::max(extent.maxCoeff(), 1.0);
  // About one facet per cell, but no more than ~8 cells per facet (empty space is cheap to
  // cross only when cells are not too small).
  double volume = 1;
  for (int a = 0; a < D; ++a) volume *= std::max(extent[a], mean_extent);
  cell_ = std::max(mean_extent, std::pow(volume / (8.0 * n), 1.0 / D));
  lo_ = lo;
  for (int a = 0; a < D; ++a) dims_[a] = static_cast<int>(std::floor(extent[a] / cell_)) + 1;
  tolerance_ = 1e-10 * (extent.maxCoeff() + lo.cwiseAbs().maxCoeff() + cell_);

  // Bucket each facet into the cells its bounding box overlaps (CSR: count, then fill).
  int64_t num_cells = 1;
  for (int a = 0; a < D; ++a) num_cells *= dims_[a];
  offsets_.assign(num_cells + 1, 0);
  auto for_each_cell_of = [&](int f, auto&& g) {
    for_each_cell_in<D>(cell_of(box_lo_[f]), cell_of(box_hi_[f]), [&](const GridIndex<D>& c) { g(linear(c)); });
  };
  for (int f = 0; f < n; ++f) for_each_cell_of(f, [&](int64_t l) { ++offsets_[l + 1]; });
  for (int64_t l = 0; l < num_cells; ++l) offsets_[l + 1] += offsets_[l];
  cell_facets_.resize(offsets_[num_cells]);
  std::vector<int64_t> fill(offsets_.begin(), offsets_.end() - 1);
  for (int f = 0; f < n; ++f) for_each_cell_of(f, [&](int64_t l) { cell_facets_[fill[l]++] = f; });
  build_tree();
}

// Leaves of at most kLeafFacets facets; median splits (nth_element, ties by index: the same tree
// for the same input).
constexpr int kLeafFacets = 4;

constexpr int kTreeStack = 128;  // > the depth of a median-split tree over 2^31 facets

template <int D>
void FacetGrid<D>::build_tree() {
  const int n = num_facets();
  tree_facets_.resize(n);
  std::iota(tree_facets_.begin(), tree_facets_.end(), 0);
  std::vector<Point<D>> centre(n);
  for (int f = 0; f < n; ++f) centre[f] = 0.5 * (box_lo_[f] + box_hi_[f]);
  tree_.assign(1, TreeNode{});
  tree_.reserve(2 * (n / kLeafFacets) + 2);
  struct Task {
    int node, first, count;
  };
  std::vector<Task> pending{{0, 0, n}};  // node ranges still to split
  while (!pending.empty()) {
    const Task t = pending.back();
    pending.pop_back();
    Point<D> lo = Point<D>::Constant(kInfinity), hi = Point<D>::Constant(-kInfinity);
    Point<D> clo = lo, chi = hi;
    for (int k = t.first; k < t.first + t.count; ++k) {
      const int f = tree_facets_[k];
      lo = lo.cwiseMin(box_lo_[f]);
      hi = hi.cwiseMax(box_hi_[f]);
      clo = clo.cwiseMin(centre[f]);
      chi = chi.cwiseMax(centre[f]);
    }
    tree_[t.node].lo = lo;
    tree_[t.node].hi = hi;
    if (t.count <= kLeafFacets) {
      tree_[t.node].first = t.first;
      tree_[t.node].count = t.count;
      continue;
    }
    int axis = 0;
    (chi - clo).maxCoeff(&axis);
    const int half = t.count / 2;
    auto begin = tree_facets_.begin() + t.first;
    std::nth_element(begin, begin + half, begin + t.count, [&](int a, int b) {
      return centre[a][axis] < centre[b][axis] || (centre[a][axis] == centre[b][axis] && a < b);
    });
    const int left = static_cast<int>(tree_.size());
    tree_.resize(tree_.size() + 2);
    tree_[t.node].first = left;
    tree_[t.node].count = 0;
    pending.push_back({left + 1, t.first + half, t.count - half});
    pending.push_back({left, t.first, half});
  }
}

// Depth first, the nearer child first; a node is skipped when its box is farther than the best
// distance so far (with the rounding slack, so that pruning never changes the result).
template <int D>
void FacetGrid<D>::tree_distance(const Point<D>& p, Scratch& s, double& best) const {
  if (tree_.empty() || prepared_.empty()) return;
  auto reach2 = [&] {
    const double r = best + tolerance_;
    return r * r;
  };
  std::array<std::pair<double, int>, kTreeStack> stack;
  int top = 0;
  stack[top++] = {box_distance2<D>(p, tree_[0].lo, tree_[0].hi), 0};
  while (top > 0) {
    const auto [d2, id] = stack[--top];
    if (d2 > reach2()) continue;
    const TreeNode& node = tree_[id];
    if (node.count > 0) {
      for (int k = node.first; k < node.first + node.count; ++k) {
        const int f = tree_facets_[k];
        if (box_distance2<D>(p, box_lo_[f], box_hi_[f]) > reach2()) continue;
        const double d = facet_distance(p, f);
        if (d < best) {
          best = d;
          s.hint = f;
        }
      }
      continue;
    }
    int a = node.first, b = node.first + 1;
    double da = box_distance2<D>(p, tree_[a].lo, tree_[a].hi), db = box_distance2<D>(p, tree_[b].lo, tree_[b].hi);
    if (db < da) std::swap(a, b), std::swap(da, db);
    DSNAKE_ASSERT(top + 2 <= kTreeStack, "the facet tree is shallower than its stack");
    if (db <= reach2()) stack[top++] = {db, b};
    if (da <= reach2()) stack[top++] = {da, a};
  }
}

template <int D>
typename FacetGrid<D>::Scratch FacetGrid<D>::make_scratch() const {
  Scratch s;
  s.stamp.assign(prepared_.size(), 0);
  return s;
}

template <int D>
GridIndex<D> FacetGrid<D>::cell_of(const Point<D>& x) const {
  GridIndex<D> c;
  for (int a = 0; a < D; ++a) {
    const double t = std::floor((x[a] - lo_[a]) / cell_);
    c[a] = t <= 0 ? 0 : (t >= dims_[a] - 1 ? dims_[a] - 1 : static_cast<int>(t));
  }
  return c;
}

template <int D>
int64_t FacetGrid<D>::linear(const GridIndex<D>& c) const {
  int64_t l = c[D - 1];
  for (int a = D - 2; a >= 0; --a) l = l * dims_[a] + c[a];
  return l;
}

template <int D>
double FacetGrid<D>::cell_box_distance2(const Point<D>& p, const GridIndex<D>& c) const {
  const Point<D> lo = lo_ + c.template cast<double>() * cell_;
  return box_distance2<D>(p, lo, lo + Point<D>::Constant(cell_));
}

template <int D>
double FacetGrid<D>::facet_distance2(const Point<D>& p, int f) const {
  return prepared_distance2<D>(p, prepared_[f]);
}

template <int D>
double FacetGrid<D>::facet_distance(const Point<D>& p, int f) const {
  return std::sqrt(facet_distance2(p, f));
}

// Tests the facets of cell c not yet seen by this query, skipping any whose box is farther
// than the best distance (with a rounding slack, so that pruning never changes the result).
template <int D>
void FacetGrid<D>::visit_cell(const Point<D>& p, const GridIndex<D>& c, Scratch& s, double& best) const {
  double reach = best + tolerance_;
  if (cell_box_distance2(p, c) > reach * reach) return;
  const int64_t l = linear(c);
  for (int64_t k = offsets_[l]; k < offsets_[l + 1]; ++k) {
    const int f = cell_facets_[k];
    if (s.stamp[f] == s.query) continue;
    s.stamp[f] = s.query;
    if (box_distance2<D>(p, box_lo_[f], box_hi_[f]) > reach * reach) continue;
    const double d = facet_distance(p, f);
    if (d < best) {
      best = d;
      reach = best + tolerance_;
      s.hint = f;
    }
  }
}

template <int D>
uint32_t FacetGrid<D>::next_query(Scratch& s) const {
  if (++s.query == 0) {
    std::fill(s.stamp.begin(), s.stamp.end(), 0);
    s.query = 1;
  }
  return s.query;
}

template <int D>
double FacetGrid<D>::distance(const Point<D>& p, Scratch& s) const {
  if (prepared_.empty()) return kInfinity;
  next_query(s);
  double best = kInfinity;
  if (s.hint >= 0 && s.hint < num_facets()) {
    best = facet_distance(p, s.hint);
    s.stamp[s.hint] = s.query;
  }
  // A point farther from the grid's box than the box is large (a collapsed or distant surface)
  // has every cell within the nearest facet's reach: when the facets are fewer than the cells,
  // testing every facet (with box culling) finds the same minimum with less work.
  double gap2 = 0;
  for (int a = 0; a < D; ++a) {
    const double g = std::max({0.0, lo_[a] - p[a], p[a] - (lo_[a] + dims_[a] * cell_)});
    gap2 += g * g;
  }
  // A point farther from the grid's box than the box is large (a collapsed or distant surface):
  // every cell is within the nearest facet's reach, so the tree answers.
  const double size = dims_.maxCoeff() * cell_;
  if (gap2 > size * size) {
    tree_distance(p, s, best);
    return best;
  }
  const GridIndex<D> c = cell_of(p);
  for (int r = 0;; ++r) {
    // A point more than a few rings from every facet (deep inside a large surface, or beside a
    // collapsed one) would walk O(r^D) empty cells: the tree finishes the search.
    if (r > kWalkRings) {
      tree_distance(p, s, best);
      return best;
    }
    // Only cells that overlap the box of half-width `best` around p can hold a nearer facet.
    GridIndex<D> lo = GridIndex<D>::Zero(), hi = dims_ - GridIndex<D>::Ones();
    if (best < kInfinity) {
      const Point<D> reach = Point<D>::Constant(best + tolerance_);
      lo = cell_of(p - reach);
      hi = cell_of(p + reach);
    }
    for_each_shell_cell<D>(c, r, lo, hi, [&](const GridIndex<D>& cell) { visit_cell(p, cell, s, best); });
    // Every unvisited facet lies in the grid's box, outside the cube of cells [c - r, c + r]:
    // beyond a face of that cube that is not on the grid's border. Its distance is at least the
    // distance along that face's axis, combined with the gaps between p and the box on the other
    // axes (p may lie outside the box, e.g. a collapsed snake far from the surface; without the
    // gaps the search would walk every cell of the grid).
    double gap2 = 0;
    Point<D> gap;
    for (int a = 0; a < D; ++a) {
      gap[a] = std::max({0.0, lo_[a] - p[a], p[a] - (lo_[a] + dims_[a] * cell_)});
      gap2 += gap[a] * gap[a];
    }
    double bound = kInfinity;
    for (int a = 0; a < D; ++a) {
      const double others = gap2 - gap[a] * gap[a];
      if (c[a] - r > 0) {
        const double d = p[a] - (lo_[a] + (c[a] - r) * cell_);
        bound = std::min(bound, std::sqrt(d * d + others));
      }
      if (c[a] + r < dims_[a] - 1) {
        const double d = lo_[a] + (c[a] + r + 1) * cell_ - p[a];
        bound = std::min(bound, std::sqrt(d * d + others));
      }
    }
    if (bound == kInfinity || bound - tolerance_ > best) break;
  }
  return best;
}

template <int D>
void FacetGrid<D>::batch_distances(const Point<D>* points, int64_t count, double* out, Scratch& s) const {
  Point<D> lo = points[0], hi = points[0];
  for (int64_t i = 1; i < count; ++i) {
    lo = lo.cwiseMin(points[i]);
    hi = hi.cwiseMax(points[i]);
  }
  if (count <= 2 || prepared_.empty() || (hi - lo).maxCoeff() > 4 * cell_) {
    for (int64_t i = 0; i < count; ++i) out[i] = distance(points[i], s);
    return;
  }
  // Upper bounds from the facet nearest to the centre (kept squared in out for now).
  distance(0.5 * (lo + hi), s);
  const int first = s.hint;
  double bound2 = 0;
  for (int64_t i = 0; i < count; ++i) {
    out[i] = facet_distance2(points[i], first);
    bound2 = std::max(bound2, out[i]);
  }
  // Every point's nearest facet has a box within `bound` of the batch's box.
  const double bound = std::sqrt(bound2) + 2 * tolerance_;
  const Point<D> lo_reach = lo - Point<D>::Constant(bound), hi_reach = hi + Point<D>::Constant(bound);
  next_query(s);
  s.stamp[first] = s.query;
  s.candidates.clear();
  const GridIndex<D> c0 = cell_of(lo_reach), c1 = cell_of(hi_reach);
  if ((c1 - c0 + GridIndex<D>::Ones()).template cast<int64_t>().prod() > kGatherCellsPerPoint * count) {
    for (int64_t i = 0; i < count; ++i) {
      double best = std::sqrt(out[i]);  // the centre's nearest facet bounds it
      tree_distance(points[i], s, best);
      out[i] = best;
    }
    return;
  }
  auto gather = [&](const GridIndex<D>& c) {
    const int64_t l = linear(c);
    for (int64_t k = offsets_[l]; k < offsets_[l + 1]; ++k) {
      const int f = cell_facets_[k];
      if (s.stamp[f] == s.query) continue;
      s.stamp[f] = s.query;
      double gap2 = 0;  // squared distance between the batch's box and the facet's box
      for (int a = 0; a < D; ++a) {
        const double e = std::max(box_lo_[f][a] - hi[a], lo[a] - box_hi_[f][a]);
        if (e > 0) gap2 += e * e;
      }
      if (gap2 <= bound * bound) s.candidates.emplace_back(std::sqrt(gap2), f);
    }
  };
  for_each_cell_in<D>(c0, c1, gather);
  std::sort(s.candidates.begin(), s.candidates.end());
  // A point's distance to a facet is at least the gap between their boxes: stop at the first
  // candidate whose gap exceeds the point's best distance.
  for (int64_t i = 0; i < count; ++i) {
    const Point<D>& p = points[i];
    double best2 = out[i];
    double reach = std::sqrt(best2) + tolerance_;
    for (const auto& [gap, f] : s.candidates) {
      if (gap > reach) break;
      if (box_distance2<D>(p, box_lo_[f], box_hi_[f]) > reach * reach) continue;
      const double d2 = facet_distance2(p, f);
      if (d2 < best2) {
        best2 = d2;
        reach = std::sqrt(best2) + tolerance_;
      }
    }
    out[i] = std::sqrt(best2);
  }
}

template <int D>
void FacetGrid<D>::overlapping_facets(int i, Scratch& s, std::vector<int>& out) const {
  out.clear();
  next_query(s);
  const Point<D> lo = box_lo_[i] - Point<D>::Constant(tolerance_);
  const Point<D> hi = box_hi_[i] + Point<D>::Constant(tolerance_);
  const GridIndex<D> c0 = cell_of(lo), c1 = cell_of(hi);
  auto visit = [&](const GridIndex<D>& c) {
    const int64_t l = linear(c);
    for (int64_t k = offsets_[l]; k < offsets_[l + 1]; ++k) {
      const int f = cell_facets_[k];
      if (f <= i || s.stamp[f] == s.query) continue;
      s.stamp[f] = s.query;
      if ((box_lo_[f].array() <= hi.array()).all() && (lo.array() <= box_hi_[f].array()).all())
        out.push_back(f);
    }
  };
  for_each_cell_in<D>(c0, c1, visit);
  std::sort(out.begin(), out.end());
}

template class FacetGrid<2>;
template class FacetGrid<3>;

}  // namespace dsnake
