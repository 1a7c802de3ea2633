#include "framework/shape.h"

#include "framework/errors.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace dsnake {

Connectivity Connectivity::polygon(int n) {
  Connectivity c;
  c.num_vertices_ = n;
  c.offsets_.resize(n + 1);
  c.adjacency_.resize(2 * n);
  for (int v = 0; v < n; ++v) {
    c.offsets_[v] = 2 * v;
    c.adjacency_[2 * v] = (v + n - 1) % n;
    c.adjacency_[2 * v + 1] = (v + 1) % n;
  }
  c.offsets_[n] = 2 * n;
  if (n < 3) c.problem_ = "a closed polygon needs at least 3 vertices, found " + std::to_string(n);
  return c;
}

Connectivity Connectivity::mesh(int n, std::vector<Triangle> triangles) {
  Connectivity c;
  c.num_vertices_ = n;
  c.triangles_ = std::move(triangles);
  const auto& tris = c.triangles_;
  auto fail = [&](std::string why) {
    if (c.problem_.empty()) c.problem_ = std::move(why);
  };
  if (tris.empty()) fail("the mesh has no triangles");

  // Directed half-edges must each appear once and have a twin: closed and consistently oriented.
  std::unordered_map<uint64_t, int> half_edges;
  half_edges.reserve(tris.size() * 3);
  auto key = [](int a, int b) { return (uint64_t(uint32_t(a)) << 32) | uint32_t(b); };
  std::vector<std::vector<int>> incident(n);
  for (size_t f = 0; f < tris.size(); ++f) {
    const auto& t = tris[f];
    for (int k = 0; k < 3; ++k) {
      if (t[k] < 0 || t[k] >= n) {
        fail("triangle " + std::to_string(f) + " refers to vertex " + std::to_string(t[k]) +
             " of " + std::to_string(n));
        return c;
      }
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      fail("triangle " + std::to_string(f) + " is degenerate (repeated vertex)");
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      incident[t[k]].push_back(static_cast<int>(f));
      if (++half_edges[key(t[k], t[(k + 1) % 3])] > 1)
        fail("edge (" + std::to_string(t[k]) + ", " + std::to_string(t[(k + 1) % 3]) +
             ") is shared by more than two triangles or oriented inconsistently");
    }
  }
  for (const auto& [k, count] : half_edges) {
    const int a = int(k >> 32), b = int(k & 0xffffffffu);
    if (!half_edges.count(key(b, a))) {
      fail("edge (" + std::to_string(std::min(a, b)) + ", " + std::to_string(std::max(a, b)) +
           ") is a boundary edge or oriented inconsistently: the mesh is not closed");
      break;
    }
  }

  // Ordered one-rings: around v, each incident triangle (v, a, b) links a -> b.
  c.offsets_.assign(n + 1, 0);
  c.adjacency_.clear();
  std::unordered_map<int, int> next;
  for (int v = 0; v < n; ++v) {
    c.offsets_[v] = static_cast<int>(c.adjacency_.size());
    if (incident[v].empty()) {
      fail("vertex " + std::to_string(v) + " is in no triangle");
      continue;
    }
    next.clear();
    for (int f : incident[v]) {
      const auto& t = tris[f];
      const int k = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
      next[t[(k + 1) % 3]] = t[(k + 2) % 3];
    }
    const int start = next.begin()->first;
    int a = start;
    size_t steps = 0;
    do {
      c.adjacency_.push_back(a);
      auto it = next.find(a);
      if (it == next.end()) break;
      a = it->second;
    } while (a != start && ++steps <= next.size());
    if (c.adjacency_.size() - c.offsets_[v] != incident[v].size()) {
      fail("vertex " + std::to_string(v) + " is non-manifold (its triangles do not form one fan)");
      // Fall back to an unordered neighbour set so that the adjacency stays usable.
      c.adjacency_.resize(c.offsets_[v]);
      std::vector<int> nb;
      for (const auto& [x, y] : next) { nb.push_back(x); nb.push_back(y); }
      std::sort(nb.begin(), nb.end());
      nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
      c.adjacency_.insert(c.adjacency_.end(), nb.begin(), nb.end());
    }
  }
  c.offsets_[n] = static_cast<int>(c.adjacency_.size());
  return c;
}

std::vector<std::array<int, 2>> Connectivity::edges() const {
  std::vector<std::array<int, 2>> e;
  for (int v = 0; v < num_vertices_; ++v)
    for (int w : neighbors(v))
      if (v < w) e.push_back({v, w});
  if (is_polygon()) {  // a polygon's neighbours are symmetric already; dedupe n == 3 etc.
    std::sort(e.begin(), e.end());
    e.erase(std::unique(e.begin(), e.end()), e.end());
  }
  return e;
}

std::string Connectivity::closed_manifold_problem() const { return problem_; }

int Connectivity::euler_characteristic() const {
  if (is_polygon()) return 0;
  return num_vertices_ - static_cast<int>(edges().size()) + static_cast<int>(triangles_.size());
}

template <int D>
Snake<D> Snake<D>::from_template(const Template<D>& tmpl, PointList<D> q) {
  DSNAKE_ASSERT(q.size() == tmpl.positions.size(), "one position per template vertex");
  std::vector<int> ids(q.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<int>(i);
  return Snake(std::move(q), tmpl.connectivity, std::move(ids));
}

template <int D>
Snake<D>::Snake(PointList<D> q, Connectivity c, std::vector<int> ids)
    : positions_(std::move(q)), connectivity_(std::move(c)), template_ids_(std::move(ids)) {
  DSNAKE_ASSERT(int(positions_.size()) == connectivity_.num_vertices() &&
                    positions_.size() == template_ids_.size(), "sizes agree");
  rebuild_inverse();
}

template <int D>
void Snake<D>::set_topology(PointList<D> q, Connectivity c, std::vector<int> ids) {
  DSNAKE_ASSERT(int(q.size()) == c.num_vertices() && q.size() == ids.size(), "sizes agree");
  positions_ = std::move(q);
  connectivity_ = std::move(c);
  template_ids_ = std::move(ids);
  rebuild_inverse();
  ++topology_version_;
}

template <int D>
void Snake<D>::rebuild_inverse() {
  int max_id = -1;
  for (int t : template_ids_) max_id = std::max(max_id, t);
  vertex_of_template_.assign(max_id + 1, -1);
  for (int v = 0; v < num_vertices(); ++v)
    if (template_ids_[v] >= 0) vertex_of_template_[template_ids_[v]] = v;
}

template <int D>
int Snake<D>::vertex_of_template_id(int t) const {
  return t >= 0 && t < int(vertex_of_template_.size()) ? vertex_of_template_[t] : -1;
}

template <int D>
int Snake<D>::num_deformation_vertices() const {
  return static_cast<int>(std::count_if(template_ids_.begin(), template_ids_.end(),
                                        [](int t) { return t >= 0; }));
}

template <int D>
PointList<D> Snake<D>::vertex_normals() const {
  PointList<D> normals;
  vertex_normals(normals);
  return normals;
}

template <>
void Snake<2>::vertex_normals(PointList<2>& normals) const {
  const int n = num_vertices();
  normals.resize(n);
  // A contour may come in either orientation (its ids are its line numbers, so it is never
  // reordered): the outward side follows the sign of the area.
  const double orientation = signed_measure() >= 0 ? 1.0 : -1.0;
  for (int v = 0; v < n; ++v) {
    const Point<2> t = positions_[(v + 1) % n] - positions_[(v + n - 1) % n];
    Point<2> nv = orientation * Point<2>(t.y(), -t.x());
    const double len = nv.norm();
    normals[v] = len > 0 ? Point<2>(nv / len) : Point<2>::Zero();
  }
}

template <>
void Snake<3>::vertex_normals(PointList<3>& normals) const {
  normals.assign(num_vertices(), Point<3>::Zero());
  for (const auto& t : connectivity_.triangles()) {
    const Point<3> fn = (positions_[t[1]] - positions_[t[0]]).cross(positions_[t[2]] - positions_[t[0]]);
    for (int k = 0; k < 3; ++k) normals[t[k]] += fn;  // area weighted
  }
  for (auto& nv : normals) {
    const double len = nv.norm();
    if (len > 0) nv /= len;
  }
}

template <>
double signed_measure<2>(const PointList<2>& p, const Connectivity&) {
  double a = 0;
  const size_t n = p.size();
  for (size_t i = 0; i < n; ++i) {
    const auto& u = p[i];
    const auto& w = p[(i + 1) % n];
    a += u.x() * w.y() - w.x() * u.y();
  }
  return 0.5 * a;
}

template <>
double signed_measure<3>(const PointList<3>& p, const Connectivity& c) {
  double v = 0;
  for (const auto& t : c.triangles()) v += p[t[0]].dot(p[t[1]].cross(p[t[2]]));
  return v / 6.0;
}

template <int D>
double Snake<D>::signed_measure() const {
  return dsnake::signed_measure<D>(positions_, connectivity_);
}

template <int D>
PointList<D> place(const PointList<D>& p, double scale, const std::vector<double>& rotation_deg,
                   const Point<D>& translation) {
  Point<D> centroid = Point<D>::Zero();
  for (const auto& x : p) centroid += x;
  if (!p.empty()) centroid /= double(p.size());
  Eigen::Matrix<double, D, D> R = Eigen::Matrix<double, D, D>::Identity();
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  if constexpr (D == 2) {
    const double a = rotation_deg.empty() ? 0.0 : rotation_deg[0] * kDeg;
    R = Eigen::Rotation2Dd(a).toRotationMatrix();
  } else {
    for (int axis = 0; axis < 3 && axis < int(rotation_deg.size()); ++axis)
      R = Eigen::AngleAxisd(rotation_deg[axis] * kDeg, Eigen::Vector3d::Unit(axis)).toRotationMatrix() * R;
  }
  PointList<D> out(p.size());
  for (size_t i = 0; i < p.size(); ++i) out[i] = centroid + scale * (R * (p[i] - centroid)) + translation;
  return out;
}

template class Snake<2>;
template class Snake<3>;
template PointList<2> place<2>(const PointList<2>&, double, const std::vector<double>&, const Point<2>&);
template PointList<3> place<3>(const PointList<3>&, double, const std::vector<double>&, const Point<3>&);

}  // namespace dsnake
