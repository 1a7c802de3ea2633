// The broad phase of the EditMesh's crossing checks (edit_mesh.h): a flat uniform grid over
// the live triangles' boxes, each triangle listed exactly in the cells its box covers, kept up to
// date as triangles come, go and move, and the queries of single edits through it; and the
// brute-force reference for tests.
#include "framework/mesh/edit_mesh.h"

#include "framework/core/errors.h"
#include "framework/geometry/triangle_pairs.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dsnake {

// Cells of two mean edges, grown if the mesh's box would need more than ~4 cells per triangle
// (a long thin mesh); the grid covers the box of the live vertices at build time.
void EditMesh::build_grid() const {
  grid_built_ = true;
  Point<3> lo = Point<3>::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  int live = 0;
  for (size_t f = 0; f < tri_.size(); ++f) {
    if (!alive_[f]) continue;
    ++live;
    for (int v : tri_[f]) {
      lo = lo.cwiseMin(pos_[v]);
      hi = hi.cwiseMax(pos_[v]);
    }
  }
  if (live == 0 || !lo.allFinite() || !hi.allFinite()) lo = hi = Point<3>::Zero();
  origin_ = lo;
  cell_ = std::max(2 * mean_edge_length(), 1e-9);
  const double max_cells = 4.0 * live + 64;
  auto count = [&](int k) { return std::floor((hi[k] - lo[k]) / cell_) + 1; };
  while (count(0) * count(1) * count(2) > max_cells) cell_ *= 1.25;
  for (int k = 0; k < 3; ++k) dims_[k] = static_cast<int>(count(k));
  cells_.assign(static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2], {});
  for (int f = 0; f < static_cast<int>(tri_.size()); ++f)
    if (alive_[f]) grid_insert(f);
}

std::array<int, 6> EditMesh::cell_range(const Point<3>& lo, const Point<3>& hi) const {
  std::array<int, 6> r;
  for (int k = 0; k < 3; ++k) {
    const double top = dims_[k] - 1;
    double a = std::floor((lo[k] - origin_[k]) / cell_), b = std::floor((hi[k] - origin_[k]) / cell_);
    a = a >= 0 ? std::min(a, top) : 0;  // also maps NaN to 0
    b = b >= 0 ? std::min(b, top) : 0;
    r[k] = static_cast<int>(a);
    r[k + 3] = static_cast<int>(b);
  }
  return r;
}

void EditMesh::grid_insert(int f) const {
  const auto& t = tri_[f];
  const Point<3> lo = pos_[t[0]].cwiseMin(pos_[t[1]]).cwiseMin(pos_[t[2]]);
  const Point<3> hi = pos_[t[0]].cwiseMax(pos_[t[1]]).cwiseMax(pos_[t[2]]);
  if (gbox_.size() <= static_cast<size_t>(f)) {
    const size_t n = std::max(tri_.capacity(), static_cast<size_t>(f) + 1);
    gbox_.resize(n);
    range_.resize(n);
  }
  set_box(f, lo, hi);
  const auto r = range_[f] = cell_range(lo, hi);
  for (int z = r[2]; z <= r[5]; ++z)
    for (int y = r[1]; y <= r[4]; ++y)
      for (int x = r[0]; x <= r[3]; ++x) cells_[x + static_cast<size_t>(dims_[0]) * (y + static_cast<size_t>(dims_[1]) * z)].push_back(f);
}

void EditMesh::set_box(int f, const Point<3>& lo, const Point<3>& hi) const {
  gbox_[f].box = outward_box(lo, hi);
}

void EditMesh::grid_erase(int f) const {
  const auto& r = range_[f];
  for (int z = r[2]; z <= r[5]; ++z)
    for (int y = r[1]; y <= r[4]; ++y)
      for (int x = r[0]; x <= r[3]; ++x) {
        auto& cell = cells_[x + static_cast<size_t>(dims_[0]) * (y + static_cast<size_t>(dims_[1]) * z)];
        auto it = std::find(cell.begin(), cell.end(), f);
        DSNAKE_ASSERT(it != cell.end(), "a triangle is missing from its grid cell");
        *it = cell.back();
        cell.pop_back();
      }
}

// A moved corner: a new box; the cell lists change only if the cell range does.
void EditMesh::grid_update(int f) const {
  const auto& t = tri_[f];
  const Point<3> lo = pos_[t[0]].cwiseMin(pos_[t[1]]).cwiseMin(pos_[t[2]]);
  const Point<3> hi = pos_[t[0]].cwiseMax(pos_[t[1]]).cwiseMax(pos_[t[2]]);
  if (cell_range(lo, hi) == range_[f]) {
    set_box(f, lo, hi);
    return;
  }
  grid_erase(f);
  grid_insert(f);
}

bool EditMesh::intersects(const Triangle& t, std::span<const int> ignore) const {
  return intersects_any(std::span<const Triangle>(&t, 1), ignore);
}

// Candidates come from the cells under the query's common box, each tested once (stamped,
// the ignored ones stamped beforehand), float box against float box (both rounded outwards,
// so a real overlap always passes; without branches, which mispredict on such data) before the
// exact pair tests, which take the double boxes.
bool EditMesh::intersects_any(std::span<const Triangle> ts, std::span<const int> ignore) const {
  if (ts.empty() || optimistic_) return false;
  if (!grid_built_) build_grid();
  if (++query_ == 0) {  // wrap-around: clear the stamps
    for (GridBox& b : gbox_) b.stamp = 0;
    query_ = 1;
  }
  for (int f : ignore)
    if (f >= 0 && static_cast<size_t>(f) < gbox_.size()) gbox_[f].stamp = query_;
  // Corners and boxes of the query triangles, and their common box; the boxes padded once.
  constexpr int kMax = 32;
  std::array<std::array<Point<3>, 3>, kMax> p;
  std::array<Point<3>, kMax> lo, hi;
  std::array<FloatBox, kMax> box;  // padded
  const int n = static_cast<int>(ts.size());
  DSNAKE_ASSERT(n <= kMax, "too many query triangles");
  Point<3> all_lo = Point<3>::Constant(std::numeric_limits<double>::infinity()), all_hi = -all_lo;
  const double pad = 1e-9 * cell_;
  for (int i = 0; i < n; ++i) {
    p[i] = {pos_[ts[i][0]], pos_[ts[i][1]], pos_[ts[i][2]]};
    lo[i] = p[i][0].cwiseMin(p[i][1]).cwiseMin(p[i][2]);
    hi[i] = p[i][0].cwiseMax(p[i][1]).cwiseMax(p[i][2]);
    box[i] = outward_box(lo[i].array() - pad, hi[i].array() + pad);
    all_lo = all_lo.cwiseMin(lo[i]);
    all_hi = all_hi.cwiseMax(hi[i]);
  }
  const Point<3> all_lo_pad = all_lo.array() - pad, all_hi_pad = all_hi.array() + pad;
  const FloatBox all = outward_box(all_lo_pad, all_hi_pad);
  const auto r = cell_range(all_lo_pad, all_hi_pad);
  std::array<Point<3>, 3> q;
  // First the candidates near the common box, in one pass without branches on the data (the
  // boxes' loads, mostly cache misses, overlap), then the tests per query triangle.
  // (candidates_ only grows: every entry is written before it is read, nothing is cleared.)
  const uint32_t query = query_;
  size_t m = 0;
  for (int z = r[2]; z <= r[5]; ++z)
    for (int y = r[1]; y <= r[4]; ++y)
      for (int x = r[0]; x <= r[3]; ++x) {
        const auto& cell = cells_[x + static_cast<size_t>(dims_[0]) * (y + static_cast<size_t>(dims_[1]) * z)];
        if (candidates_.size() < m + cell.size()) candidates_.resize(2 * (m + cell.size()));
        int* out = candidates_.data();
        for (int f : cell) {
          GridBox& b = gbox_[f];
          const bool skip = (b.stamp == query) | boxes_apart(b.box, all);
          b.stamp = query;
          out[m] = f;
          m += !skip;
        }
      }
  for (size_t j = 0; j < m; ++j) {
    const int f = candidates_[j];
    const GridBox& b = gbox_[f];
    const auto& s = tri_[f];
    bool loaded = false;  // f's corners and box, fetched for the first query triangle near it
    Point<3> qlo, qhi;
    for (int i = 0; i < n; ++i) {
      if (boxes_apart(b.box, box[i])) continue;
      if (!loaded) {
        q = {pos_[s[0]], pos_[s[1]], pos_[s[2]]};
        qlo = q[0].cwiseMin(q[1]).cwiseMin(q[2]);
        qhi = q[0].cwiseMax(q[1]).cwiseMax(q[2]);
        loaded = true;
      }
      if (pair_conflicts(ts[i], p[i], lo[i], hi[i], s, q, qlo, qhi)) return true;
    }
  }
  return false;
}

void EditMesh::drop_grid() {
  grid_built_ = false;
  cells_ = {};
  gbox_ = {};
  range_ = {};
}

bool EditMesh::intersects_any_brute_force(std::span<const Triangle> ts, std::span<const int> ignore) const {
  for (int f = 0; f < static_cast<int>(tri_.size()); ++f) {
    if (!alive_[f] || std::find(ignore.begin(), ignore.end(), f) != ignore.end()) continue;
    const auto& s = tri_[f];
    const std::array<Point<3>, 3> q = {pos_[s[0]], pos_[s[1]], pos_[s[2]]};
    const Point<3> slo = q[0].cwiseMin(q[1]).cwiseMin(q[2]), shi = q[0].cwiseMax(q[1]).cwiseMax(q[2]);
    for (const auto& t : ts) {
      const std::array<Point<3>, 3> p = {pos_[t[0]], pos_[t[1]], pos_[t[2]]};
      const Point<3> lo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), hi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
      if (pair_conflicts(t, p, lo, hi, s, q, slo, shi)) return true;
    }
  }
  return false;
}

}  // namespace dsnake
