#include "remesh/mesh_edit.h"

#include "framework/errors.h"
#include "framework/metrics_geometry.h"
#include "framework/vector_clones.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace dsnake::remesh_detail {

namespace {

// x as a float at most / at least x (box filters that never reject a real overlap): moved
// outwards by 2^-20 relative (plus a tiny absolute term) before the conversion, whose
// rounding is at most 2^-24 relative. Cheaper than nextafter, and only a filter.
float float_down(double x) { return static_cast<float>(x - (std::abs(x) * 0x1p-20 + 1e-30)); }
float float_up(double x) { return static_cast<float>(x + (std::abs(x) * 0x1p-20 + 1e-30)); }

// [lo, hi] as a FloatBox that contains it.
FloatBox outward(const Point<3>& lo, const Point<3>& hi) {
  FloatBox b;
  for (int k = 0; k < 3; ++k) b.lo[k] = float_down(lo[k]), b.hi[k] = float_up(hi[k]);
  return b;
}

// Boxes entirely apart along some axis (without branches, which mispredict on such data).
bool apart(const FloatBox& a, const FloatBox& b) {
  return (a.lo[0] > b.hi[0]) | (a.lo[1] > b.hi[1]) | (a.lo[2] > b.hi[2]) | (b.lo[0] > a.hi[0]) |
         (b.lo[1] > a.hi[1]) | (b.lo[2] > a.hi[2]);
}

constexpr double kFoldCos = 0.990268;  // cos(8 degrees): closer than that across an edge is a fold
constexpr double kVerifyCell = 2.0;    // end_optimistic's grid cell, in mean edges

// Closed segment [p, q] against the closed triangle (a, b, c), Moller-Trumbore; a segment
// parallel to the triangle's plane counts as missing it (the coplanar case is left to the
// fold and normal checks of the edits). Two cheap rejections come first: disjoint boxes, and
// both ends strictly on one side of the plane (by a relative margin of 1e-9, far above
// rounding, so that the exact test could only have said "no" as well: t would be outside
// [0, 1] by more than 1e-9).
// tlo, thi: the triangle's bounding box (the caller has it).
bool segment_hits_triangle(const Point<3>& p, const Point<3>& q, const Point<3>& a, const Point<3>& b,
                           const Point<3>& c, const Point<3>& tlo, const Point<3>& thi) {
  const double slack = 1e-9 * (thi - tlo).maxCoeff();
  if ((p.cwiseMax(q).array() < tlo.array() - slack).any() || (p.cwiseMin(q).array() > thi.array() + slack).any())
    return false;
  const Point<3> e1 = b - a, e2 = c - a;
  const Point<3> n = e1.cross(e2);
  const double dp = n.dot(p - a), dq = n.dot(q - a);
  if ((dp > 0 && dq > 0) || (dp < 0 && dq < 0)) {
    const double small = std::min(std::abs(dp), std::abs(dq)), large = std::max(std::abs(dp), std::abs(dq));
    if (small > 1e-9 * large) return false;
  }
  const Point<3> d = q - p;
  const Point<3> h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = d.norm() * e1.norm() * e2.norm();
  if (std::abs(det) <= 1e-12 * scale) return false;
  const double inv = 1.0 / det;
  const Point<3> s = p - a;
  const double u = inv * s.dot(h);
  if (u < -1e-12 || u > 1 + 1e-12) return false;
  const Point<3> qv = s.cross(e1);
  const double v = inv * d.dot(qv);
  if (v < -1e-12 || u + v > 1 + 1e-12) return false;
  const double t = inv * e2.dot(qv);
  return t >= -1e-12 && t <= 1 + 1e-12;
}

// true if the three points lie strictly on one side of the plane of triangle q, by a margin
// (1e-10 of |n|_1 |x - q0|_inf, which bounds |n . (x - q0)|) far above rounding: then the
// two triangles cannot meet, whatever the exact test would compute.
bool strictly_one_side(const std::array<Point<3>, 3>& p, const std::array<Point<3>, 3>& q) {
  const Point<3> n = (q[1] - q[0]).cross(q[2] - q[0]);
  const double n1 = n.lpNorm<1>();
  int above = 0, below = 0;
  for (const auto& x : p) {
    const Point<3> r = x - q[0];
    const double d = n.dot(r), margin = 1e-10 * n1 * r.lpNorm<Eigen::Infinity>();
    if (d > margin) ++above;
    else if (d < -margin) ++below;
  }
  return above == 3 || below == 3;
}

// Whether triangles A and B (vertex ids ta, tb, positions pa, pb) conflict, given the vertices
// they share: disjoint ones must not touch; with one shared vertex, neither opposite edge may
// pierce the other triangle; with a shared edge, they must not fold onto each other.
// loa, hia, lob, hib: the triangles' bounding boxes.
bool pair_conflicts(const Triangle& ta, const std::array<Point<3>, 3>& pa, const Point<3>& loa, const Point<3>& hia,
                    const Triangle& tb, const std::array<Point<3>, 3>& pb, const Point<3>& lob, const Point<3>& hib) {
  int shared = 0, ia = -1, ib = -1;  // ia/ib: a shared corner's index in A/B
  int sa[3] = {0, 0, 0}, sb[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (ta[i] == tb[j]) { ++shared; sa[i] = 1; sb[j] = 1; ia = i; ib = j; }
  if (shared == 0) {
    if (strictly_one_side(pa, pb) || strictly_one_side(pb, pa)) return false;
    return detail::triangles_intersect(pa, pb);
  }
  if (shared == 3) return true;  // a duplicate triangle
  if (shared == 1) {
    return segment_hits_triangle(pa[(ia + 1) % 3], pa[(ia + 2) % 3], pb[0], pb[1], pb[2], lob, hib) ||
           segment_hits_triangle(pb[(ib + 1) % 3], pb[(ib + 2) % 3], pa[0], pa[1], pa[2], loa, hia);
  }
  // Shared edge: the opening angle between the two half-planes must exceed 8 degrees.
  int oa = 0, ob = 0;
  while (sa[oa]) ++oa;
  while (sb[ob]) ++ob;
  const Point<3>& u = pa[(oa + 1) % 3];
  const Point<3> e = (pa[(oa + 2) % 3] - u).normalized();
  Point<3> xa = pa[oa] - u, xb = pb[ob] - u;
  xa -= xa.dot(e) * e;
  xb -= xb.dot(e) * e;
  const double na = xa.norm(), nb = xb.norm();
  if (na == 0 || nb == 0) return true;
  return xa.dot(xb) / (na * nb) > kFoldCos;
}

}  // namespace

Point<3> triangle_normal(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const Point<3> n = (b - a).cross(c - a);
  const double len = n.norm();
  return len > 0 ? Point<3>(n / len) : Point<3>(Point<3>::Zero());
}

double triangle_area(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  return 0.5 * (b - a).cross(c - a).norm();
}

double angle_at(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const Point<3> u = b - a, v = c - a;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

// The smallest angle is the one opposite the shortest edge (law of sines): one atan2, not three
// (the same value as the smallest of the three, up to ties within rounding).
double min_angle(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const double ab = (b - a).squaredNorm(), bc = (c - b).squaredNorm(), ca = (a - c).squaredNorm();
  if (bc <= ab && bc <= ca) return angle_at(a, b, c);
  if (ca <= ab) return angle_at(b, c, a);
  return angle_at(c, a, b);
}

EditMesh::EditMesh(const Snake<3>& snake)
    : pos_(snake.positions()), ids_(snake.template_ids()), vfan_(snake.num_vertices()) {
  const auto& c = snake.connectivity();
  const std::string problem = c.closed_manifold_problem();
  if (!problem.empty()) throw InputError("", "remeshing input mesh", problem);
  for (auto& list : vfan_) list.reserve(8);  // valence 6 and a little more without regrowth
  tri_.reserve(c.triangles().size() * 2);
  alive_.reserve(c.triangles().size() * 2);
  for (const auto& t : c.triangles()) add_triangle(t);
  changed_ = connectivity_changed_ = false;
}

double EditMesh::mean_edge_length() const {
  if (mean_edge_known_) return mean_edge_;
  mean_edge_known_ = true;
  double total = 0;
  int count = 0;
  for (size_t f = 0; f < tri_.size(); ++f) {
    if (!alive_[f]) continue;
    const auto& t = tri_[f];
    for (int k = 0; k < 3; ++k) {
      total += (pos_[t[k]] - pos_[t[(k + 1) % 3]]).norm();
      ++count;
    }
  }
  return mean_edge_ = count > 0 ? total / count : 1.0;
}

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
  gbox_[f].box = outward(lo, hi);
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

void EditMesh::triangles_of(int v, std::vector<int>& out) const {
  out.clear();
  for (const Corner& c : vfan_[v]) out.push_back(c.f);
}

// Each triangle (v, a, b) of the fan links a -> b (a corner's next -> prev); the ring follows
// the links from the first triangle's a.
void EditMesh::ring(int v, std::vector<int>& out) const {
  out.clear();
  const auto& fan = vfan_[v];
  if (fan.empty()) return;
  const int start = fan[0].next;
  int a = start;
  do {
    out.push_back(a);
    int to = -1;
    for (const Corner& c : fan)
      if (c.next == a) {
        to = c.prev;
        break;
      }
    a = to;
  } while (a >= 0 && a != start && out.size() <= fan.size());
  DSNAKE_ASSERT(a == start && out.size() == fan.size(), "one-ring of a vertex is not a closed fan");
}

void EditMesh::move_vertex(int v, const Point<3>& p) {
  pos_[v] = p;
  changed_ = true;
  if (optimistic_)
    for (const Corner& c : vfan_[v]) dirty_[c.f] = 1;
  if (grid_built_)
    for (const Corner& c : vfan_[v]) grid_update(c.f);
}

int EditMesh::add_vertex(const Point<3>& p) {
  pos_.push_back(p);
  ids_.push_back(-1);
  vfan_.emplace_back();
  changed_ = connectivity_changed_ = true;
  return num_vertices() - 1;
}

int EditMesh::add_triangle(const Triangle& t) {
  const int f = static_cast<int>(tri_.size());
  tri_.push_back(t);
  alive_.push_back(1);
  if (optimistic_) dirty_.push_back(1);
  for (int k = 0; k < 3; ++k) {
    auto& fan = vfan_[t[k]];
    if (fan.empty()) ++live_vertices_;
    fan.push_back({f, t[(k + 1) % 3], t[(k + 2) % 3]});
  }
  if (grid_built_) grid_insert(f);
  changed_ = connectivity_changed_ = true;
  return f;
}

void EditMesh::remove_triangle(int f) {
  if (!alive_[f]) return;
  alive_[f] = 0;
  for (int v : tri_[f]) {
    auto& fan = vfan_[v];
    fan.erase(std::find_if(fan.begin(), fan.end(), [f](const Corner& c) { return c.f == f; }));
    if (fan.empty()) --live_vertices_;
  }
  if (grid_built_) grid_erase(f);
  changed_ = connectivity_changed_ = true;
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
    box[i] = outward(lo[i].array() - pad, hi[i].array() + pad);
    all_lo = all_lo.cwiseMin(lo[i]);
    all_hi = all_hi.cwiseMax(hi[i]);
  }
  const Point<3> all_lo_pad = all_lo.array() - pad, all_hi_pad = all_hi.array() + pad;
  const FloatBox all = outward(all_lo_pad, all_hi_pad);
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
          const bool skip = (b.stamp == query) | apart(b.box, all);
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
      if (apart(b.box, box[i])) continue;
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

void EditMesh::begin_optimistic() {
  drop_grid();
  optimistic_ = true;
  dirty_.assign(tri_.size(), 0);
}

// True if v's fan cannot hold a conflicting pair (the tests of intersects_any on two of its
// triangles would all say no): with n the fan's area-weighted normal, every triangle's normal is
// within 80 degrees of n, so that two triangles sharing an edge open by more than 20 degrees
// (no fold), and the fan projects one-to-one onto the plane normal to n (each triangle turns
// counter-clockwise about v by an angle whose sine is above 1e-6, and the ring winds once), so
// that two triangles sharing only v are apart but for v.
bool EditMesh::fan_is_embedded(int v) const {
  constexpr double kCos80 = 0.17364817766693041, kMinSine = 1e-6;
  const auto& fan = vfan_[v];
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
// they share no vertex and their boxes overlap (the negation of apart(), by columns). No
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

}  // namespace

bool EditMesh::end_optimistic(bool verify) {
  optimistic_ = false;
  std::vector<uint8_t> dirty = std::move(dirty_);
  dirty_ = {};
  if (!verify) return true;
  const int F = static_cast<int>(tri_.size());
  auto corners_of = [&](int f) {
    return std::array<Point<3>, 3>{pos_[tri_[f][0]], pos_[tri_[f][1]], pos_[tri_[f][2]]};
  };
  auto conflict = [&](int f, int g) {
    const auto p = corners_of(f), q = corners_of(g);
    const Point<3> plo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), phi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    const Point<3> qlo = q[0].cwiseMin(q[1]).cwiseMin(q[2]), qhi = q[0].cwiseMax(q[1]).cwiseMax(q[2]);
    return pair_conflicts(tri_[f], p, plo, phi, tri_[g], q, qlo, qhi);
  };
  // Pairs sharing a vertex (in parallel: the answer is whether any pair conflicts, the same
  // for any thread count).
  const int n = num_vertices();
  bool found = false;
#pragma omp parallel for schedule(static) reduction(|| : found) if (n >= 4096)
  for (int v = 0; v < n; ++v) {
    const auto& fan = vfan_[v];
    bool marked = false;
    for (const Corner& c : fan) marked |= dirty[c.f] != 0;
    if (found || !marked || fan_is_embedded(v)) continue;
    for (size_t i = 0; i < fan.size(); ++i)
      for (size_t j = i + 1; j < fan.size(); ++j)
        found = found || ((dirty[fan[i].f] || dirty[fan[j].f]) && conflict(fan[i].f, fan[j].f));
  }
  if (found) return false;
  // Pairs sharing no vertex: boxes of the live triangles (in a compact list), grown by 1e-8 of
  // the cell and of their own size, and the grid over them (cells grown while there would be
  // more than 8 per triangle).
  // (References to this thread's buffers: the parallel loop below shares them.)
  VerifyScratch& scratch = verify_scratch();
  std::vector<int>& live = scratch.live;
  live.clear();
  Point<3> all_lo = Point<3>::Constant(std::numeric_limits<double>::infinity()), all_hi = -all_lo;
  for (int f = 0; f < F; ++f) {
    if (!alive_[f]) continue;
    live.push_back(f);
    for (int v : tri_[f]) all_lo = all_lo.cwiseMin(pos_[v]), all_hi = all_hi.cwiseMax(pos_[v]);
  }
  const int L = static_cast<int>(live.size());
  if (L == 0 || !all_lo.allFinite() || !all_hi.allFinite()) return true;
  DSNAKE_ASSERT(L < (1 << 28), "too many triangles for the check's entries (index << 3 | start bits)");
  double cell = std::max(kVerifyCell * mean_edge_length(), 1e-9);
  auto count = [&](int k) { return std::floor((all_hi[k] - all_lo[k]) / cell) + 3; };
  while (count(0) * count(1) * count(2) > 8.0 * L + 64) cell *= 1.25;
  const Point<3> origin = all_lo.array() - cell;
  const std::array<int, 3> dims = {static_cast<int>(count(0)), static_cast<int>(count(1)),
                                   static_cast<int>(count(2))};
  auto cell_of = [&](double x, int k) {
    return std::clamp(static_cast<int>(std::floor((x - origin[k]) / cell)), 0, dims[k] - 1);
  };
  // Per live triangle its cell range and its entry (VerifyEntry), then the entries per cell.
  std::vector<std::array<int, 6>>& range = scratch.range;
  std::vector<VerifyEntry>& proto = scratch.proto;
  std::vector<int>& start = scratch.start;
  range.resize(L);
  proto.resize(L);
  start.assign(static_cast<size_t>(dims[0]) * dims[1] * dims[2] + 1, 0);
  auto index = [&](int x, int y, int z) {
    return x + static_cast<size_t>(dims[0]) * (y + static_cast<size_t>(dims[1]) * z);
  };
  for (int i = 0; i < L; ++i) {
    const auto p = corners_of(live[i]);
    Point<3> lo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), hi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    const double grow = 1e-8 * (cell + (hi - lo).maxCoeff());
    lo.array() -= grow, hi.array() += grow;
    auto& r = range[i];
    VerifyEntry& e = proto[i];
    for (int k = 0; k < 3; ++k) r[k] = cell_of(lo[k], k), r[k + 3] = cell_of(hi[k], k);
    e.box = outward(lo, hi);
    e.t = tri_[live[i]], e.id = live[i], e.marked = dirty[live[i]];
    for (int z = r[2]; z <= r[5]; ++z)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int x = r[0]; x <= r[3]; ++x) ++start[index(x, y, z) + 1];
  }
  for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  // The entries in cell order: first which triangle (and its start bits) each one is, one
  // scattered write per entry, then the columns in order (ten scattered writes per entry
  // would cost more than the pair loop gains from the columns).
  VerifyColumns& columns = scratch.columns;
  std::vector<int>& fill = scratch.fill;
  std::vector<int>& slot = scratch.slot;
  slot.resize(start.back());
  fill.assign(start.begin(), start.end() - 1);
  for (int i = 0; i < L; ++i) {
    const auto& r = range[i];
    for (int z = r[2]; z <= r[5]; ++z)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int x = r[0]; x <= r[3]; ++x)
          slot[fill[index(x, y, z)]++] = i << 3 | (x == r[0]) | (y == r[1]) << 1 | (z == r[2]) << 2;
  }
  columns.resize(slot.size());
  for (size_t e = 0; e < slot.size(); ++e) columns.set(e, proto[slot[e] >> 3], slot[e] & 7);
  // A pair is taken in the cell of its overlap's low corner: there, on each axis, one of the
  // two ranges starts (the larger first cell; the cell map is monotone).
#pragma omp parallel for schedule(dynamic, 1) reduction(|| : found) if (L >= 8192)
  for (int z = 0; z < dims[2]; ++z)
    for (int y = 0; y < dims[1]; ++y)
      for (int x = 0; x < dims[0] && !found; ++x) {
        const size_t c = index(x, y, z);
        const int end = start[c + 1];
        for (int i = start[c]; i < end && !found; ++i) {
          if (!any_pair_to_test(columns, i, i + 1, end)) continue;  // (most rows)
          for (int j = i + 1; j < end && !found; ++j)
            found = any_pair_to_test(columns, i, j, j + 1) && conflict(columns.id[i], columns.id[j]);
        }
      }
  return !found;
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

int EditMesh::commit(Snake<3>& snake) {
  if (!changed_) return snake.num_vertices();
  if (!connectivity_changed_) {  // positions only (uniform): the topology version stays, so
    // energies keep their factorisations (only free vertices moved; remesher.h)
    std::copy(pos_.begin(), pos_.end(), snake.positions().begin());
    changed_ = false;
    return snake.num_vertices();
  }
  std::vector<int> remap(pos_.size(), -1);
  PointList<3> q;
  std::vector<int> ids;
  q.reserve(live_vertices_);
  ids.reserve(live_vertices_);
  size_t corners = 0;
  for (int v = 0; v < num_vertices(); ++v) {
    if (vfan_[v].empty()) {
      DSNAKE_ASSERT(ids_[v] < 0, "a remesher dropped a deformation vertex");
      continue;
    }
    remap[v] = static_cast<int>(q.size());
    q.push_back(pos_[v]);
    ids.push_back(ids_[v]);
    corners += vfan_[v].size();
  }
  std::vector<Triangle> tris;
  tris.reserve(corners / 3);
  for (size_t f = 0; f < tri_.size(); ++f)
    if (alive_[f]) tris.push_back({remap[tri_[f][0]], remap[tri_[f][1]], remap[tri_[f][2]]});
  // The ordered rings as Connectivity::mesh orders them: a vertex's corners are in triangle
  // order (added in order, removed in place), so its first corner is its first triangle, whose
  // next vertex starts ring() (which asserts one closed fan).
  const int n = static_cast<int>(q.size());
  std::vector<int> offsets(n + 1, 0), adjacency, ring_of_v;
  adjacency.reserve(corners);
  for (int v = 0; v < num_vertices(); ++v) {
    if (remap[v] < 0) continue;
    offsets[remap[v]] = static_cast<int>(adjacency.size());
    ring(v, ring_of_v);
    for (int a : ring_of_v) adjacency.push_back(remap[a]);
  }
  offsets[n] = static_cast<int>(adjacency.size());
  snake.set_topology(std::move(q), Connectivity::manifold_mesh(n, std::move(tris), std::move(offsets), std::move(adjacency)),
                     std::move(ids));
  changed_ = connectivity_changed_ = false;
  return n;
}

FlipResult try_flip(EditMesh& m, int a, int b, double cos_max_dihedral) {
  const int f1 = m.face_with_edge(a, b), f2 = m.face_with_edge(b, a);
  if (f1 < 0 || f2 < 0) return FlipResult::kTopology;
  return try_flip(m, a, b, f1, f2, m.opposite(f1, a, b), m.opposite(f2, b, a), cos_max_dihedral);
}

FlipResult try_flip(EditMesh& m, int a, int b, int f1, int f2, int c, int d, double cos_max_dihedral) {
  if (c == d || m.valence(a) <= 3 || m.valence(b) <= 3 || m.has_edge(c, d)) return FlipResult::kTopology;
  const Point<3> n1 = triangle_normal(m.pos(a), m.pos(b), m.pos(c));
  const Point<3> n2 = triangle_normal(m.pos(b), m.pos(a), m.pos(d));
  const Triangle t3 = {a, d, c}, t4 = {d, b, c};
  const Point<3> n3 = triangle_normal(m.pos(a), m.pos(d), m.pos(c));
  const Point<3> n4 = triangle_normal(m.pos(d), m.pos(b), m.pos(c));
  if (n1.dot(n2) < cos_max_dihedral || n3.dot(n4) < cos_max_dihedral || n3.squaredNorm() == 0 ||
      n4.squaredNorm() == 0 || n3.dot(n1 + n2) <= 0 || n4.dot(n1 + n2) <= 0)
    return FlipResult::kRejected;
  const int ignore[2] = {f1, f2};
  const Triangle fresh[2] = {t3, t4};
  if (m.intersects_any(fresh, ignore)) return FlipResult::kRejected;
  m.remove_triangle(f1);
  m.remove_triangle(f2);
  m.add_triangle(t3);
  m.add_triangle(t4);
  return FlipResult::kFlipped;
}

}  // namespace dsnake::remesh_detail
