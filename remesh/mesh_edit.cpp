#include "remesh/mesh_edit.h"

#include "framework/errors.h"
#include "framework/metrics_geometry.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace dsnake::remesh_detail {

namespace {

constexpr double kFoldCos = 0.990268;  // cos(8 degrees): closer than that across an edge is a fold

// Closed segment [p, q] against the closed triangle (a, b, c), Moller-Trumbore; a segment
// parallel to the triangle's plane counts as missing it (the coplanar case is left to the
// fold and normal checks of the edits).
bool segment_hits_triangle(const Point<3>& p, const Point<3>& q, const Point<3>& a, const Point<3>& b,
                           const Point<3>& c) {
  const Point<3> tlo = a.cwiseMin(b).cwiseMin(c), thi = a.cwiseMax(b).cwiseMax(c);
  const double slack = 1e-9 * (thi - tlo).maxCoeff();
  if ((p.cwiseMax(q).array() < tlo.array() - slack).any() || (p.cwiseMin(q).array() > thi.array() + slack).any())
    return false;
  const Point<3> d = q - p, e1 = b - a, e2 = c - a;
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

// Whether triangles A and B (vertex ids ta, tb, positions pa, pb) conflict, given the vertices
// they share: disjoint ones must not touch; with one shared vertex, neither opposite edge may
// pierce the other triangle; with a shared edge, they must not fold onto each other.
bool pair_conflicts(const Triangle& ta, const std::array<Point<3>, 3>& pa, const Triangle& tb,
                    const std::array<Point<3>, 3>& pb) {
  int shared = 0, ia = -1, ib = -1;  // ia/ib: a shared corner's index in A/B
  int sa[3] = {0, 0, 0}, sb[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (ta[i] == tb[j]) { ++shared; sa[i] = 1; sb[j] = 1; ia = i; ib = j; }
  if (shared == 0) return detail::triangles_intersect(pa, pb);
  if (shared == 3) return true;  // a duplicate triangle
  if (shared == 1) {
    return segment_hits_triangle(pa[(ia + 1) % 3], pa[(ia + 2) % 3], pb[0], pb[1], pb[2]) ||
           segment_hits_triangle(pb[(ib + 1) % 3], pb[(ib + 2) % 3], pa[0], pa[1], pa[2]);
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

double min_angle(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  return std::min({angle_at(a, b, c), angle_at(b, c, a), angle_at(c, a, b)});
}

EditMesh::EditMesh(const Snake<3>& snake)
    : pos_(snake.positions()), ids_(snake.template_ids()), vtri_(snake.num_vertices()) {
  const auto& c = snake.connectivity();
  const std::string problem = c.closed_manifold_problem();
  if (!problem.empty()) throw InputError("", "remeshing input mesh", problem);
  double total = 0;
  int count = 0;
  origin_ = pos_.empty() ? Point<3>(Point<3>::Zero()) : pos_[0];
  for (const auto& t : c.triangles())
    for (int k = 0; k < 3; ++k) {
      total += (pos_[t[k]] - pos_[t[(k + 1) % 3]]).norm();
      ++count;
    }
  mean_edge_ = count > 0 ? total / count : 1.0;
  cell_ = std::max(2 * mean_edge_, 1e-9);
  tri_.reserve(c.triangles().size() * 2);
  for (const auto& t : c.triangles()) add_triangle(t);
  changed_ = connectivity_changed_ = false;
}

int64_t EditMesh::cell_key(int x, int y, int z) const {
  constexpr int64_t kOff = 1 << 20;
  return ((int64_t(x) + kOff) << 42) | ((int64_t(y) + kOff) << 21) | (int64_t(z) + kOff);
}

void EditMesh::build_grid() const {
  grid_built_ = true;
  grid_.reserve(tri_.size());
  for (int f = 0; f < static_cast<int>(tri_.size()); ++f)
    if (alive_[f]) grid_insert(f);
}

void EditMesh::grid_insert(int f) const {
  const auto& t = tri_[f];
  Point<3> lo = pos_[t[0]], hi = pos_[t[0]];
  for (int k = 1; k < 3; ++k) {
    lo = lo.cwiseMin(pos_[t[k]]);
    hi = hi.cwiseMax(pos_[t[k]]);
  }
  if (box_lo_.size() <= static_cast<size_t>(f)) {
    box_lo_.resize(tri_.capacity());
    box_hi_.resize(tri_.capacity());
  }
  box_lo_[f] = lo;
  box_hi_[f] = hi;
  const Eigen::Vector3i a = ((lo - origin_) / cell_).array().floor().cast<int>();
  const Eigen::Vector3i b = ((hi - origin_) / cell_).array().floor().cast<int>();
  for (int x = a.x(); x <= b.x(); ++x)
    for (int y = a.y(); y <= b.y(); ++y)
      for (int z = a.z(); z <= b.z(); ++z) grid_[cell_key(x, y, z)].push_back(f);
}

void EditMesh::ring(int v, std::vector<int>& out) const {
  out.clear();
  const auto& fan = vtri_[v];
  if (fan.empty()) return;
  // next[a] = b for each triangle (v, a, b) in counter-clockwise order.
  auto next_of = [&](int a) {
    for (int f : fan) {
      const auto& t = tri_[f];
      for (int k = 0; k < 3; ++k)
        if (t[k] == v && t[(k + 1) % 3] == a) return t[(k + 2) % 3];
    }
    return -1;
  };
  const auto& t0 = tri_[fan[0]];
  int start = -1;
  for (int k = 0; k < 3; ++k)
    if (t0[k] == v) start = t0[(k + 1) % 3];
  int a = start;
  do {
    out.push_back(a);
    a = next_of(a);
  } while (a >= 0 && a != start && out.size() <= fan.size());
  DSNAKE_ASSERT(a == start && out.size() == fan.size(), "one-ring of a vertex is not a closed fan");
}

int EditMesh::face_with_edge(int a, int b) const {
  for (int f : vtri_[a]) {
    const auto& t = tri_[f];
    for (int k = 0; k < 3; ++k)
      if (t[k] == a && t[(k + 1) % 3] == b) return f;
  }
  return -1;
}

int EditMesh::opposite(int f, int a, int b) const {
  const auto& t = tri_[f];
  for (int k = 0; k < 3; ++k)
    if (t[k] != a && t[k] != b) return t[k];
  return -1;
}

void EditMesh::move_vertex(int v, const Point<3>& p) {
  pos_[v] = p;
  changed_ = true;
  // Stale cells keep the triangle listed; the box test in intersects() skips it there.
  if (grid_built_)
    for (int f : vtri_[v]) grid_insert(f);
}

int EditMesh::add_vertex(const Point<3>& p) {
  pos_.push_back(p);
  ids_.push_back(-1);
  vtri_.emplace_back();
  changed_ = connectivity_changed_ = true;
  return num_vertices() - 1;
}

int EditMesh::add_triangle(const Triangle& t) {
  const int f = static_cast<int>(tri_.size());
  tri_.push_back(t);
  alive_.push_back(1);
  for (int v : t) vtri_[v].push_back(f);
  if (grid_built_) grid_insert(f);
  changed_ = connectivity_changed_ = true;
  return f;
}

void EditMesh::remove_triangle(int f) {
  if (!alive_[f]) return;
  alive_[f] = 0;
  for (int v : tri_[f]) {
    auto& list = vtri_[v];
    list.erase(std::find(list.begin(), list.end(), f));
  }
  changed_ = connectivity_changed_ = true;
}

bool EditMesh::intersects(const Triangle& t, std::span<const int> ignore) const {
  return intersects_any(std::span<const Triangle>(&t, 1), ignore);
}

bool EditMesh::intersects_any(std::span<const Triangle> ts, std::span<const int> ignore) const {
  if (ts.empty()) return false;
  if (!grid_built_) build_grid();
  if (stamp_.size() < tri_.size()) stamp_.resize(tri_.size() + tri_.size() / 2 + 16, 0);
  if (++query_ == 0) {  // wrap-around: clear the stamps
    std::fill(stamp_.begin(), stamp_.end(), 0);
    query_ = 1;
  }
  // Corners and boxes of the query triangles, and their common box.
  constexpr int kMax = 32;
  std::array<std::array<Point<3>, 3>, kMax> p;
  std::array<Point<3>, kMax> lo, hi;
  const int n = static_cast<int>(ts.size());
  DSNAKE_ASSERT(n <= kMax, "too many query triangles");
  Point<3> all_lo = Point<3>::Constant(std::numeric_limits<double>::infinity()), all_hi = -all_lo;
  for (int i = 0; i < n; ++i) {
    p[i] = {pos_[ts[i][0]], pos_[ts[i][1]], pos_[ts[i][2]]};
    lo[i] = p[i][0].cwiseMin(p[i][1]).cwiseMin(p[i][2]);
    hi[i] = p[i][0].cwiseMax(p[i][1]).cwiseMax(p[i][2]);
    all_lo = all_lo.cwiseMin(lo[i]);
    all_hi = all_hi.cwiseMax(hi[i]);
  }
  const double pad = 1e-9 * cell_;
  const Eigen::Vector3i a = ((all_lo.array() - pad - origin_.array()) / cell_).floor().cast<int>();
  const Eigen::Vector3i b = ((all_hi.array() + pad - origin_.array()) / cell_).floor().cast<int>();
  for (int x = a.x(); x <= b.x(); ++x)
    for (int y = a.y(); y <= b.y(); ++y)
      for (int z = a.z(); z <= b.z(); ++z) {
        auto it = grid_.find(cell_key(x, y, z));
        if (it == grid_.end()) continue;
        for (int f : it->second) {
          if (!alive_[f] || stamp_[f] == query_) continue;
          stamp_[f] = query_;
          // Cheap box rejection (cached boxes) before the exact tests.
          const Point<3>& flo = box_lo_[f];
          const Point<3>& fhi = box_hi_[f];
          if ((flo.array() > all_hi.array() + pad).any() || (fhi.array() < all_lo.array() - pad).any()) continue;
          if (std::find(ignore.begin(), ignore.end(), f) != ignore.end()) continue;
          const auto& s = tri_[f];
          const std::array<Point<3>, 3> q = {pos_[s[0]], pos_[s[1]], pos_[s[2]]};
          for (int i = 0; i < n; ++i) {
            if ((flo.array() > hi[i].array() + pad).any() || (fhi.array() < lo[i].array() - pad).any()) continue;
            if (pair_conflicts(ts[i], p[i], s, q)) return true;
          }
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
  for (int v = 0; v < num_vertices(); ++v) {
    if (vtri_[v].empty()) {
      DSNAKE_ASSERT(ids_[v] < 0, "a remesher dropped a deformation vertex");
      continue;
    }
    remap[v] = static_cast<int>(q.size());
    q.push_back(pos_[v]);
    ids.push_back(ids_[v]);
  }
  std::vector<Triangle> tris;
  for (size_t f = 0; f < tri_.size(); ++f)
    if (alive_[f]) tris.push_back({remap[tri_[f][0]], remap[tri_[f][1]], remap[tri_[f][2]]});
  const int n = static_cast<int>(q.size());
  snake.set_topology(std::move(q), Connectivity::mesh(n, std::move(tris)), std::move(ids));
  changed_ = connectivity_changed_ = false;
  return n;
}

FlipResult try_flip(EditMesh& m, int a, int b, double cos_max_dihedral) {
  const int f1 = m.face_with_edge(a, b), f2 = m.face_with_edge(b, a);
  if (f1 < 0 || f2 < 0) return FlipResult::kTopology;
  const int c = m.opposite(f1, a, b), d = m.opposite(f2, b, a);
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
