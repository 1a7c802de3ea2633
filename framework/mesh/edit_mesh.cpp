// EditMesh (edit_mesh.h): construction from a snake, the local edits, the one-rings and the
// write-back; and the edge flip the stages share. The crossing checks live in
// edit_mesh_broad_phase.cpp (the grid for single edits) and edit_mesh_optimistic_check.cpp (one
// check of a stage's result).
#include "framework/mesh/edit_mesh.h"

#include "framework/core/errors.h"
#include "framework/geometry/triangle_measures.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>

namespace dsnake {

void CornerFans::push(int v, const MeshCorner& corner) {
  const int c = count_[v];
  if (!(c & kSpilled) && c < kInline) {
    inline_[size_t(v) * kInline + c] = corner;
    ++count_[v];
    return;
  }
  if (!(c & kSpilled)) {  // the first corner past kInline: the corners move to a list of their own
    if (slot_.size() < count_.size()) slot_.resize(count_.size(), -1);
    slot_[v] = int(spilled_.size());
    const MeshCorner* block = inline_.data() + size_t(v) * kInline;
    spilled_.emplace_back(block, block + c);
    count_[v] |= kSpilled;
  }
  spilled_[size_t(slot_[v])].push_back(corner);
  ++count_[v];
}

int CornerFans::erase_face(int v, int f) {
  auto is_f = [f](const MeshCorner& c) { return c.f == f; };
  int at;
  if (count_[v] & kSpilled) {
    auto& list = spilled_[size_t(slot_[v])];
    const auto hit = std::find_if(list.begin(), list.end(), is_f);
    at = int(hit - list.begin());
    list.erase(hit);
  } else {
    MeshCorner* first = inline_.data() + size_t(v) * kInline;
    MeshCorner* last = first + count_[v];
    MeshCorner* hit = std::find_if(first, last, is_f);
    at = int(hit - first);
    std::move(hit + 1, last, hit);
  }
  --count_[v];
  return at;
}

void CornerFans::pop(int v) {
  if (count_[v] & kSpilled) spilled_[size_t(slot_[v])].pop_back();
  --count_[v];
}

// push, then the new last corner rotated back to `at` (a spilled vertex stays spilled).
void CornerFans::insert(int v, int at, const MeshCorner& corner) {
  push(v, corner);
  const int n = size(v);
  MeshCorner* first = count_[v] & kSpilled ? spilled_[size_t(slot_[v])].data() : inline_.data() + size_t(v) * kInline;
  std::rotate(first + at, first + n - 1, first + n);
}

EditMesh::EditMesh(const Snake<3>& snake)
    : pos_(snake.positions()), ids_(snake.template_ids()), vfan_(snake.num_vertices()),
      changed_at_(snake.num_vertices(), 0) {
  const auto& c = snake.connectivity();
  const std::string problem = c.closed_manifold_problem();
  if (!problem.empty()) throw InputError("", "remeshing input mesh", problem);
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

void EditMesh::triangles_of(int v, std::vector<int>& out) const {
  out.clear();
  for (const Corner& c : vfan_.of(v)) out.push_back(c.f);
}

// Each triangle (v, a, b) of the fan links a -> b (a corner's next -> prev); the ring follows
// the links from the first triangle's a.
void EditMesh::ring(int v, std::vector<int>& out) const {
  out.clear();
  const auto fan = vfan_.of(v);
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
  changed_at_[v] = ++clock_;
  changed_ = true;
  if (optimistic_)
    for (const Corner& c : vfan_.of(v)) dirty_[c.f] = 1;
  if (grid_built_)
    for (const Corner& c : vfan_.of(v)) grid_update(c.f);
}

int EditMesh::add_vertex(const Point<3>& p) {
  pos_.push_back(p);
  ids_.push_back(-1);
  changed_at_.push_back(++clock_);
  vfan_.add_vertex();
  changed_ = connectivity_changed_ = true;
  return num_vertices() - 1;
}

int EditMesh::add_triangle(const Triangle& t) {
  const int f = static_cast<int>(tri_.size());
  tri_.push_back(t);
  alive_.push_back(1);
  if (optimistic_) dirty_.push_back(1);
  for (int k = 0; k < 3; ++k) {
    if (vfan_.size(t[k]) == 0) ++live_vertices_;
    vfan_.push(t[k], {f, t[(k + 1) % 3], t[(k + 2) % 3]});
    changed_at_[t[k]] = clock_ + 1;
  }
  if (grid_built_) grid_insert(f);
  changed_ = connectivity_changed_ = true;
  ++clock_;
  return f;
}

void EditMesh::remove_triangle(int f, std::array<int, 3>* at) {
  if (!alive_[f]) return;
  alive_[f] = 0;
  for (int k = 0; k < 3; ++k) {
    const int v = tri_[f][k];
    const int where = vfan_.erase_face(v, f);
    if (at) (*at)[k] = where;
    if (vfan_.size(v) == 0) --live_vertices_;
    changed_at_[v] = clock_ + 1;
  }
  ++clock_;
  if (grid_built_) grid_erase(f);
  changed_ = connectivity_changed_ = true;
}

void EditMesh::undo_flip(const FlipRecord& r) {
  const int last = num_triangle_slots() - 1;
  DSNAKE_ASSERT(last >= 1 && alive_[last] && alive_[last - 1] && !alive_[r.f1] && !alive_[r.f2],
                "undo_flip: the flip is the mesh's last edit");
  // The new triangles' corners were pushed last (t3's, then t4's): off in reverse.
  for (int f = last; f >= last - 1; --f) {
    for (int k = 2; k >= 0; --k) {
      DSNAKE_ASSERT(corners(tri_[f][k]).back().f == f, "undo_flip: the flip is the mesh's last edit");
      vfan_.pop(tri_[f][k]);
    }
    if (grid_built_) grid_erase(f);
    tri_.pop_back();
    alive_.pop_back();
    if (optimistic_) dirty_.pop_back();
  }
  // f2 was removed after f1, each corner after the one before: back in reverse, where they stood.
  for (const auto& [f, at] : {std::pair{r.f2, r.at2}, std::pair{r.f1, r.at1}}) {
    const Triangle& t = tri_[f];
    for (int k = 2; k >= 0; --k) vfan_.insert(t[k], at[k], {f, t[(k + 1) % 3], t[(k + 2) % 3]});
    alive_[f] = 1;
    if (grid_built_) grid_insert(f);
  }
  changed_ = r.changed, connectivity_changed_ = r.connectivity_changed;
  for (const auto& [v, at] : r.changed_at) changed_at_[v] = at;
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
    if (vfan_.size(v) == 0) {
      DSNAKE_ASSERT(ids_[v] < 0, "a remesher dropped a deformation vertex");
      continue;
    }
    remap[v] = static_cast<int>(q.size());
    q.push_back(pos_[v]);
    ids.push_back(ids_[v]);
    corners += size_t(vfan_.size(v));
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

FlipResult try_flip(EditMesh& m, int a, int b, int f1, int f2, int c, int d, double cos_max_dihedral,
                    EditMesh::FlipRecord* record) {
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
  if (record)
    *record = {f1, f2, {}, {}, m.changed(), m.connectivity_changed(),
               {{{a, m.changed_at(a)}, {b, m.changed_at(b)}, {c, m.changed_at(c)}, {d, m.changed_at(d)}}}};
  m.remove_triangle(f1, record ? &record->at1 : nullptr);
  m.remove_triangle(f2, record ? &record->at2 : nullptr);
  m.add_triangle(t3);
  m.add_triangle(t4);
  return FlipResult::kFlipped;
}

}  // namespace dsnake
