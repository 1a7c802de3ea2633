#include "framework/core/shape.h"

#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace dsnake {

Connectivity Connectivity::manifold_mesh(int n, std::vector<Triangle> triangles, std::vector<int> offsets,
                                         std::vector<int> adjacency) {
  DSNAKE_ASSERT(!triangles.empty() && offsets.size() == static_cast<size_t>(n) + 1 && offsets.front() == 0 &&
                    offsets.back() == static_cast<int>(adjacency.size()) && adjacency.size() == 3 * triangles.size(),
                "a closed manifold mesh's rings: one CSR entry per corner");
  Connectivity c;
  c.num_vertices_ = n;
  c.triangles_ = std::move(triangles);
  c.offsets_ = std::move(offsets);
  c.adjacency_ = std::move(adjacency);
  return c;
}

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

namespace {

// The first problem found is the one reported: later ones do not overwrite it.
void set_problem(std::string& problem, std::string why) {
  if (problem.empty()) problem = std::move(why);
}

// A triangle with a repeated vertex: left out of the rings and the half-edges, and reported.
bool degenerate(const Triangle& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }

// Incident non-degenerate triangles of each vertex, in triangle order (CSR: `incident` from
// first_incident[v] to first_incident[v + 1]); returns the first degenerate triangle (or F).
int incident_triangles(int n, const std::vector<Triangle>& tris, std::vector<int>& first_incident,
                       std::vector<int>& incident) {
  const int F = static_cast<int>(tris.size());
  int first_degenerate = F;
  first_incident.assign(n + 1, 0);
  for (int f = 0; f < F; ++f) {
    if (degenerate(tris[f])) {
      first_degenerate = std::min(first_degenerate, f);
      continue;
    }
    for (int k = 0; k < 3; ++k) ++first_incident[tris[f][k] + 1];
  }
  for (int v = 0; v < n; ++v) first_incident[v + 1] += first_incident[v];
  incident.resize(first_incident[n]);
  {
    std::vector<int> fill(first_incident.begin(), first_incident.end() - 1);
    for (int f = 0; f < F; ++f)
      if (!degenerate(tris[f]))
        for (int k = 0; k < 3; ++k) incident[fill[tris[f][k]]++] = f;
  }
  return first_degenerate;
}

// A directed half-edge a -> b at position 3 f + k, ordered by (b, position).
struct Outgoing {
  int to, position;
  bool operator<(const Outgoing& o) const { return to != o.to ? to < o.to : position < o.position; }
};

// The directed half-edges a -> b of the non-degenerate triangles, per vertex a sorted by
// (b, position) (the CSR layout of `incident`); returns the position of the earliest second
// occurrence of a half-edge (3 F if none).
int sorted_half_edges(int n, const std::vector<Triangle>& tris, const std::vector<int>& first_incident,
                      const std::vector<int>& incident, std::vector<Outgoing>& outgoing) {
  const int F = static_cast<int>(tris.size());
  outgoing.resize(incident.size());
  int first_repeat = 3 * F;  // position of the earliest second occurrence of a half-edge
  for (int a = 0; a < n; ++a) {
    const auto begin = outgoing.begin() + first_incident[a], end = outgoing.begin() + first_incident[a + 1];
    for (int i = first_incident[a]; i < first_incident[a + 1]; ++i) {
      const int f = incident[i];
      const int k = tris[f][0] == a ? 0 : (tris[f][1] == a ? 1 : 2);
      outgoing[i] = {tris[f][(k + 1) % 3], 3 * f + k};
    }
    std::sort(begin, end);
    for (auto it = begin; it != end && it + 1 != end; ++it)
      if (it[1].to == it->to) first_repeat = std::min(first_repeat, it[1].position);
  }
  return first_repeat;
}

// A repeated half-edge is shared by more than two triangles or oriented inconsistently; one
// without its twin b -> a is on a boundary. The first problem in triangle order is reported
// (a degenerate triangle or the earliest second occurrence of a half-edge; then the missing
// twin of the smallest (a, b)).
void check_edges(int n, const std::vector<Triangle>& tris, int first_degenerate, int first_repeat,
                 const std::vector<int>& first_incident, const std::vector<Outgoing>& outgoing,
                 std::string& problem) {
  const int F = static_cast<int>(tris.size());
  if (first_degenerate < F && first_degenerate <= first_repeat / 3) {
    set_problem(problem, "triangle " + std::to_string(first_degenerate) + " is degenerate (repeated vertex)");
  } else if (first_repeat < 3 * F) {
    const auto& t = tris[first_repeat / 3];
    const int k = first_repeat % 3;
    set_problem(problem, "edge (" + std::to_string(t[k]) + ", " + std::to_string(t[(k + 1) % 3]) +
                             ") is shared by more than two triangles or oriented inconsistently");
  }
  for (int a = 0; a < n && problem.empty(); ++a)
    for (int i = first_incident[a]; i < first_incident[a + 1]; ++i) {
      const int b = outgoing[i].to;
      const auto b_begin = outgoing.begin() + first_incident[b], b_end = outgoing.begin() + first_incident[b + 1];
      const auto twin = std::lower_bound(b_begin, b_end, Outgoing{a, -1});
      if (twin == b_end || twin->to != a) {
        set_problem(problem, "edge (" + std::to_string(std::min(a, b)) + ", " + std::to_string(std::max(a, b)) +
                                 ") is a boundary edge or oriented inconsistently: the mesh is not closed");
        break;
      }
    }
}

// Ordered one-rings in CSR form: around v, each incident triangle (v, a, b) links a -> b; the
// ring starts at the first incident triangle's a. A vertex whose triangles are not one fan gets
// its unordered neighbour set, so that the adjacency stays usable.
void ordered_rings(int n, const std::vector<Triangle>& tris, const std::vector<int>& first_incident,
                   const std::vector<int>& incident, std::vector<int>& offsets, std::vector<int>& adjacency,
                   std::string& problem) {
  offsets.assign(n + 1, 0);
  adjacency.clear();
  adjacency.reserve(incident.size());
  std::vector<std::pair<int, int>> links;
  for (int v = 0; v < n; ++v) {
    offsets[v] = static_cast<int>(adjacency.size());
    if (first_incident[v] == first_incident[v + 1]) {
      set_problem(problem, "vertex " + std::to_string(v) + " is in no triangle");
      continue;
    }
    links.clear();
    for (int i = first_incident[v]; i < first_incident[v + 1]; ++i) {
      const auto& t = tris[incident[i]];
      const int k = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
      links.push_back({t[(k + 1) % 3], t[(k + 2) % 3]});
    }
    auto next_of = [&](int a) {
      for (const auto& [from, to] : links)
        if (from == a) return to;
      return -1;
    };
    const int start = links.front().first;
    int a = start;
    size_t steps = 0;
    do {
      adjacency.push_back(a);
      a = next_of(a);
    } while (a >= 0 && a != start && ++steps <= links.size());
    if (adjacency.size() - offsets[v] != links.size()) {
      set_problem(problem, "vertex " + std::to_string(v) + " is non-manifold (its triangles do not form one fan)");
      adjacency.resize(offsets[v]);
      std::vector<int> nb;
      for (const auto& [x, y] : links) nb.push_back(x), nb.push_back(y);
      std::sort(nb.begin(), nb.end());
      nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
      adjacency.insert(adjacency.end(), nb.begin(), nb.end());
    }
  }
  offsets[n] = static_cast<int>(adjacency.size());
}

}  // namespace

// Flat arrays throughout (it runs after every remeshing pass): incident triangles in CSR form,
// the directed half-edges sorted once for the duplicate and twin checks, and each one-ring
// walked through a linear search of its few (a -> b) links. Linear in the mesh size.
Connectivity Connectivity::mesh(int n, std::vector<Triangle> triangles) {
  Connectivity c;
  c.num_vertices_ = n;
  c.triangles_ = std::move(triangles);
  const auto& tris = c.triangles_;
  const int F = static_cast<int>(tris.size());
  if (tris.empty()) set_problem(c.problem_, "the mesh has no triangles");
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k)
      if (tris[f][k] < 0 || tris[f][k] >= n) {
        set_problem(c.problem_, "triangle " + std::to_string(f) + " refers to vertex " + std::to_string(tris[f][k]) +
                                    " of " + std::to_string(n));
        return c;
      }
  std::vector<int> first_incident, incident;
  const int first_degenerate = incident_triangles(n, tris, first_incident, incident);
  std::vector<Outgoing> outgoing;
  const int first_repeat = sorted_half_edges(n, tris, first_incident, incident, outgoing);
  check_edges(n, tris, first_degenerate, first_repeat, first_incident, outgoing, c.problem_);
  ordered_rings(n, tris, first_incident, incident, c.offsets_, c.adjacency_, c.problem_);
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

template <>
void vertex_normals<2>(const PointList<2>& p, const Connectivity& c, PointList<2>& normals) {
  const int n = static_cast<int>(p.size());
  normals.resize(n);
  // A contour may come in either orientation (its ids are its line numbers, so it is never
  // reordered): the outward side follows the sign of the area.
  const double orientation = signed_measure<2>(p, c) >= 0 ? 1.0 : -1.0;
  for (int v = 0; v < n; ++v) {
    const Point<2> t = p[(v + 1) % n] - p[(v + n - 1) % n];
    Point<2> nv = orientation * Point<2>(t.y(), -t.x());
    const double len = nv.norm();
    normals[v] = len > 0 ? Point<2>(nv / len) : Point<2>::Zero();
  }
}

template <>
void vertex_normals<3>(const PointList<3>& p, const Connectivity& c, PointList<3>& normals) {
  normals.assign(p.size(), Point<3>::Zero());
  for (const auto& t : c.triangles()) {
    const Point<3> fn = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
    for (int k = 0; k < 3; ++k) normals[t[k]] += fn;  // area weighted
  }
  for (auto& nv : normals) {
    const double len = nv.norm();
    if (len > 0) nv /= len;
  }
}

template <int D>
void Snake<D>::vertex_normals(PointList<D>& normals) const {
  dsnake::vertex_normals<D>(positions_, connectivity_, normals);
}

template <int D>
PointList<D> vertex_normals(const PointList<D>& p, const Connectivity& c) {
  PointList<D> normals;
  vertex_normals<D>(p, c, normals);
  return normals;
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

template PointList<2> vertex_normals<2>(const PointList<2>&, const Connectivity&);
template PointList<3> vertex_normals<3>(const PointList<3>&, const Connectivity&);
template class Snake<2>;
template class Snake<3>;
template PointList<2> place<2>(const PointList<2>&, double, const std::vector<double>&, const Point<2>&);
template PointList<3> place<3>(const PointList<3>&, double, const std::vector<double>&, const Point<3>&);

}  // namespace dsnake
