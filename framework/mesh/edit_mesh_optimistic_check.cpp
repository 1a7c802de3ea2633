// The optimistic check of the EditMesh (edit_mesh.h, remesh/pass.h): edits made without a
// crossing test mark the triangles they create or move; end_optimistic() then tests each marked
// triangle once against the final mesh, the pairs that share a vertex fan by fan and those that
// share none through a grid of its own over the final mesh.
#include "framework/mesh/edit_mesh.h"

#include "framework/core/errors.h"
#include "framework/core/vector_clones.h"
#include "framework/geometry/triangle_pairs.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dsnake {

void EditMesh::begin_optimistic() {
  drop_grid();
  optimistic_ = true;
  dirty_.assign(tri_.size(), 0);
  regularization_memo_ = {};
}

// True if v's fan cannot hold a conflicting pair (the tests of intersects_any on two of its
// triangles would all say no): with n the fan's area-weighted normal, every triangle's normal is
// within 80 degrees of n, so that two triangles sharing an edge open by more than 20 degrees
// (no fold), and the fan projects one-to-one onto the plane normal to n (each triangle turns
// counter-clockwise about v by an angle whose sine is above 1e-6, and the ring winds once), so
// that two triangles sharing only v are apart but for v.
bool EditMesh::fan_is_embedded(int v) const {
  constexpr double kCos80 = 0.17364817766693041, kMinSine = 1e-6;
  const auto fan = vfan_.of(v);
  const int k = static_cast<int>(fan.size());
  if (k < 3 || k > 64) return false;
  const Point<3>& x = pos_[v];
  std::array<Point<3>, 64> normal;
  Point<3> n = Point<3>::Zero();
  for (int i = 0; i < k; ++i) n += normal[i] = (pos_[fan[i].next] - x).cross(pos_[fan[i].prev] - x);
  const double length = n.norm();
  if (!(length > 0)) return false;
  n /= length;
  // In-plane axes e1, e2 (e1 from the axis least aligned with n).
  int least = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(n[a]) < std::abs(n[least])) least = a;
  const Point<3> e1 = n.cross(Point<3>::Unit(least)).normalized(), e2 = n.cross(e1);
  int winding = 0;
  for (int i = 0; i < k; ++i) {
    const Point<3> a = pos_[fan[i].next] - x, b = pos_[fan[i].prev] - x;
    const double turn = normal[i].dot(n);  // = the projected cross product of a and b
    // (Both tests squared, as turn > 0: no roots.)
    if (!(turn > 0) || !(turn * turn > kCos80 * kCos80 * normal[i].squaredNorm())) return false;
    const double ax = a.dot(e1), ay = a.dot(e2), bx = b.dot(e1), by = b.dot(e2);
    if (!(turn * turn > kMinSine * kMinSine * ((ax * ax + ay * ay) * (bx * bx + by * by)))) return false;
    winding += ay < 0 && by >= 0;  // a counter-clockwise step across the positive e1 axis
  }
  return winding == 1;
}

// Two parts, together every pair intersects_any would test with at least one marked triangle:
// pairs that share a vertex v lie in v's fan, cleared by fan_is_embedded or else tested pair by
// pair; pairs that share no vertex come from a grid of two mean edges over the final mesh,
// each triangle listed in the cells its box covers and a pair taken in the one cell holding the
// low corner of the boxes' overlap (boxes grown slightly beyond intersects_any's padding).
namespace {

// end_optimistic's grid, per live triangle: its float box, its corners, its id, its mark.
struct VerifyEntry {
  FloatBox box;
  Triangle t;
  int id;
  uint8_t marked;
};

// The grid's entries (a triangle once per cell it covers, the cells one after the other) as
// columns, so that the pair filter runs over a cell's entries in wide vectors: the float box,
// the corners, flags (bit k < 3: the triangle's cell range starts in this cell on axis k;
// bit 3: marked) and the triangle's id.
struct VerifyColumns {
  std::array<std::vector<float>, 3> lo, hi;
  std::array<std::vector<int>, 3> t;
  std::vector<int> flags, id;

  void resize(size_t n) {
    for (int k = 0; k < 3; ++k) lo[k].resize(n), hi[k].resize(n), t[k].resize(n);
    flags.resize(n);
    id.resize(n);
  }
  void set(size_t e, const VerifyEntry& v, int starts) {
    for (int k = 0; k < 3; ++k) lo[k][e] = v.box.lo[k], hi[k][e] = v.box.hi[k], t[k][e] = v.t[k];
    flags[e] = starts | v.marked << 3;
    id[e] = v.id;
  }
};

// Whether entry i and one of the entries [j0, j1) make a pair to test: between them their
// ranges start here on every axis (the cell of their overlap's low corner), one is marked,
// they share no vertex and their boxes overlap (the negation of boxes_apart(), by columns). No
// branch: most entries of a cell pass some filters and fail others, which a branch per filter
// would mispredict.
DSNAKE_VECTOR_CLONES bool any_pair_to_test(const VerifyColumns& g, int i, int j0, int j1) {
  const float alo0 = g.lo[0][i], alo1 = g.lo[1][i], alo2 = g.lo[2][i];
  const float ahi0 = g.hi[0][i], ahi1 = g.hi[1][i], ahi2 = g.hi[2][i];
  const int a0 = g.t[0][i], a1 = g.t[1][i], a2 = g.t[2][i], fa = g.flags[i];
  const float *lo0 = g.lo[0].data(), *lo1 = g.lo[1].data(), *lo2 = g.lo[2].data();
  const float *hi0 = g.hi[0].data(), *hi1 = g.hi[1].data(), *hi2 = g.hi[2].data();
  const int *t0 = g.t[0].data(), *t1 = g.t[1].data(), *t2 = g.t[2].data(), *flags = g.flags.data();
  int any = 0;
#pragma omp simd reduction(| : any)
  for (int j = j0; j < j1; ++j) {
    const int both = ((fa | flags[j]) & 15) == 15;
    const int shared = (a0 == t0[j]) | (a0 == t1[j]) | (a0 == t2[j]) | (a1 == t0[j]) | (a1 == t1[j]) |
                       (a1 == t2[j]) | (a2 == t0[j]) | (a2 == t1[j]) | (a2 == t2[j]);
    const int overlap = (alo0 <= hi0[j]) & (alo1 <= hi1[j]) & (alo2 <= hi2[j]) & (lo0[j] <= ahi0) &
                        (lo1[j] <= ahi1) & (lo2[j] <= ahi2);
    any |= both & !shared & overlap;
  }
  return any != 0;
}

// The grid's buffers, kept from one check to the next by the thread that builds the grid (in
// fresh buffers of this size, every check would fault in a few megabytes of pages).
struct VerifyScratch {
  std::vector<int> live, start, fill, slot;
  std::vector<std::array<int, 6>> range;
  std::vector<VerifyEntry> proto;
  VerifyColumns columns;
};

VerifyScratch& verify_scratch() {
  static thread_local VerifyScratch scratch;
  return scratch;
}

constexpr double kVerifyCell = 2.0;  // end_optimistic's grid cell, in mean edges

std::array<Point<3>, 3> corners_of(const EditMesh& m, int f) {
  const Triangle& t = m.tri(f);
  return {m.pos(t[0]), m.pos(t[1]), m.pos(t[2])};
}

// Whether live triangles f and g conflict (the pair tests of intersects_any).
bool conflict(const EditMesh& m, int f, int g) {
  const auto p = corners_of(m, f), q = corners_of(m, g);
  const Point<3> plo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), phi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
  const Point<3> qlo = q[0].cwiseMin(q[1]).cwiseMin(q[2]), qhi = q[0].cwiseMax(q[1]).cwiseMax(q[2]);
  return pair_conflicts(m.tri(f), p, plo, phi, m.tri(g), q, qlo, qhi);
}

// Whether a pair of triangles sharing a vertex, one of them marked, conflicts (in parallel: the
// answer is whether any pair conflicts, the same for any thread count).
bool shared_vertex_conflict(const EditMesh& m, const std::vector<uint8_t>& dirty) {
  const int n = m.num_vertices();
  bool found = false;
#pragma omp parallel for schedule(static) reduction(|| : found) if (n >= 4096)
  for (int v = 0; v < n; ++v) {
    const auto fan = m.corners(v);
    bool marked = false;
    for (const EditMesh::Corner& c : fan) marked |= dirty[c.f] != 0;
    if (found || !marked || m.fan_is_embedded(v)) continue;
    for (size_t i = 0; i < fan.size(); ++i)
      for (size_t j = i + 1; j < fan.size(); ++j)
        found = found || ((dirty[fan[i].f] || dirty[fan[j].f]) && conflict(m, fan[i].f, fan[j].f));
  }
  return found;
}

// The check's grid for the pairs sharing no vertex: dims cells of size cell from origin.
struct VerifyGrid {
  Point<3> origin;
  double cell;
  std::array<int, 3> dims;

  size_t index(int x, int y, int z) const {
    return x + static_cast<size_t>(dims[0]) * (y + static_cast<size_t>(dims[1]) * z);
  }
  int cell_of(double x, int k) const {
    return std::clamp(static_cast<int>(std::floor((x - origin[k]) / cell)), 0, dims[k] - 1);
  }
  size_t num_cells() const { return static_cast<size_t>(dims[0]) * dims[1] * dims[2]; }
};

// The live triangles into `live` (a compact list) and the grid over them: cells of kVerifyCell
// mean edges, grown while there would be more than 8 per triangle, with a border cell on each
// side. false if there is nothing to check.
bool plan_grid(const EditMesh& m, std::vector<int>& live, VerifyGrid& grid) {
  live.clear();
  Point<3> all_lo = Point<3>::Constant(std::numeric_limits<double>::infinity()), all_hi = -all_lo;
  const int F = m.num_triangle_slots();
  for (int f = 0; f < F; ++f) {
    if (!m.tri_alive(f)) continue;
    live.push_back(f);
    for (int v : m.tri(f)) all_lo = all_lo.cwiseMin(m.pos(v)), all_hi = all_hi.cwiseMax(m.pos(v));
  }
  const int L = static_cast<int>(live.size());
  if (L == 0 || !all_lo.allFinite() || !all_hi.allFinite()) return false;
  DSNAKE_ASSERT(L < (1 << 28), "too many triangles for the check's entries (index << 3 | start bits)");
  double cell = std::max(kVerifyCell * m.mean_edge_length(), 1e-9);
  auto count = [&](int k) { return std::floor((all_hi[k] - all_lo[k]) / cell) + 3; };
  while (count(0) * count(1) * count(2) > 8.0 * L + 64) cell *= 1.25;
  grid.origin = all_lo.array() - cell;
  grid.cell = cell;
  grid.dims = {static_cast<int>(count(0)), static_cast<int>(count(1)), static_cast<int>(count(2))};
  return true;
}

// Per live triangle its cell range (its box grown by 1e-8 of the cell and of its own size) and
// its entry (VerifyEntry); scratch.start: the first entry of each cell (prefix sums of the counts).
void list_boxes(const EditMesh& m, const std::vector<uint8_t>& dirty, const VerifyGrid& grid, VerifyScratch& scratch) {
  const std::vector<int>& live = scratch.live;
  const int L = static_cast<int>(live.size());
  std::vector<std::array<int, 6>>& range = scratch.range;
  std::vector<VerifyEntry>& proto = scratch.proto;
  std::vector<int>& start = scratch.start;
  range.resize(L);
  proto.resize(L);
  start.assign(grid.num_cells() + 1, 0);
  for (int i = 0; i < L; ++i) {
    const auto p = corners_of(m, live[i]);
    Point<3> lo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), hi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    const double grow = 1e-8 * (grid.cell + (hi - lo).maxCoeff());
    lo.array() -= grow, hi.array() += grow;
    auto& r = range[i];
    VerifyEntry& e = proto[i];
    for (int k = 0; k < 3; ++k) r[k] = grid.cell_of(lo[k], k), r[k + 3] = grid.cell_of(hi[k], k);
    e.box = outward_box(lo, hi);
    e.t = m.tri(live[i]), e.id = live[i], e.marked = dirty[live[i]];
    for (int z = r[2]; z <= r[5]; ++z)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int x = r[0]; x <= r[3]; ++x) ++start[grid.index(x, y, z) + 1];
  }
  for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
}

// The entries in cell order: first which triangle (and its start bits) each one is, one
// scattered write per entry, then the columns in order (ten scattered writes per entry would
// cost more than the pair loop gains from the columns).
void fill_columns(const VerifyGrid& grid, VerifyScratch& scratch) {
  const int L = static_cast<int>(scratch.live.size());
  const std::vector<std::array<int, 6>>& range = scratch.range;
  std::vector<int>& fill = scratch.fill;
  std::vector<int>& slot = scratch.slot;
  slot.resize(scratch.start.back());
  fill.assign(scratch.start.begin(), scratch.start.end() - 1);
  for (int i = 0; i < L; ++i) {
    const auto& r = range[i];
    for (int z = r[2]; z <= r[5]; ++z)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int x = r[0]; x <= r[3]; ++x)
          slot[fill[grid.index(x, y, z)]++] = i << 3 | (x == r[0]) | (y == r[1]) << 1 | (z == r[2]) << 2;
  }
  scratch.columns.resize(slot.size());
  for (size_t e = 0; e < slot.size(); ++e) scratch.columns.set(e, scratch.proto[slot[e] >> 3], slot[e] & 7);
}

// Whether a pair sharing no vertex, one of them marked, conflicts. A pair is taken in the cell
// of its overlap's low corner: there, on each axis, one of the two ranges starts (the larger
// first cell; the cell map is monotone).
bool apart_pair_conflict(const EditMesh& m, const std::vector<uint8_t>& dirty) {
  // (References to this thread's buffers: the parallel loop below shares them.)
  VerifyScratch& scratch = verify_scratch();
  VerifyGrid grid;
  if (!plan_grid(m, scratch.live, grid)) return false;
  list_boxes(m, dirty, grid, scratch);
  fill_columns(grid, scratch);
  const int L = static_cast<int>(scratch.live.size());
  const VerifyColumns& columns = scratch.columns;
  const std::vector<int>& start = scratch.start;
  const std::array<int, 3> dims = grid.dims;
  bool found = false;
#pragma omp parallel for schedule(dynamic, 1) reduction(|| : found) if (L >= 8192)
  for (int z = 0; z < dims[2]; ++z)
    for (int y = 0; y < dims[1]; ++y)
      for (int x = 0; x < dims[0] && !found; ++x) {
        const size_t c = grid.index(x, y, z);
        const int end = start[c + 1];
        for (int i = start[c]; i < end && !found; ++i) {
          if (!any_pair_to_test(columns, i, i + 1, end)) continue;  // (most rows)
          for (int j = i + 1; j < end && !found; ++j)
            found = any_pair_to_test(columns, i, j, j + 1) && conflict(m, columns.id[i], columns.id[j]);
        }
      }
  return found;
}

}  // namespace

bool EditMesh::end_optimistic(bool verify) {
  optimistic_ = false;
  std::vector<uint8_t> dirty = std::move(dirty_);
  dirty_ = {};
  regularization_memo_ = {};
  if (!verify) return true;
  return !shared_vertex_conflict(*this, dirty) && !apart_pair_conflict(*this, dirty);
}

}  // namespace dsnake
