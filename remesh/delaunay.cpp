#include "remesh/delaunay.h"

#include "framework/mesh/edit_mesh.h"
#include "framework/geometry/triangle_measures.h"
#include "remesh/stage_steps.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

namespace dsnake {

namespace {


// An edge a -> b as listed: with the triangle that held it then (triangles never change, so
// while that one lives it still holds a -> b).
struct ListedEdge {
  int a, b, f, k;  // a = tri(f)[k], b = tri(f)[k + 1]
};

// Every undirected edge once, in a fixed order (determinism), into `edges` (a buffer reused
// across sweeps: growing it anew each time costs more in page faults than the listing).
void all_edges(const EditMesh& m, std::vector<ListedEdge>& edges) {
  edges.clear();
  for (int f = 0; f < m.num_triangle_slots(); ++f) {
    if (!m.tri_alive(f)) continue;
    const auto& t = m.tri(f);
    for (int k = 0; k < 3; ++k)
      if (t[k] < t[(k + 1) % 3]) edges.push_back({t[k], t[(k + 1) % 3], f, k});
  }
}

// Intrinsic Delaunay criterion: the angles opposite edge a-b, measured in its two triangles,
// sum to more than pi (the empty-circumcircle test on the unfolded pair).
// c and d: the vertices opposite a -> b and b -> a.
bool is_delaunay_violation(const EditMesh& m, int a, int b, int c, int d) {
  // Cheap filter first: with u, v the edges from c and from d to a and b, and gamma, delta the
  // two angles, s = |u_c x v_c| (u_d . v_d) + (u_c . v_c) |u_d x v_d| is sin(gamma + delta)
  // times the four lengths; gamma + delta is in [0, 2 pi], so sin > 1e-6 means a sum below
  // pi (no violation) and sin < -1e-6 a sum above pi + 1e-6 (a violation), with margins far
  // above rounding. Only sums within ~1e-6 of pi (or degenerate triangles) take the atan2s.
  const Point<3> uc = m.pos(a) - m.pos(c), vc = m.pos(b) - m.pos(c);
  const Point<3> ud = m.pos(a) - m.pos(d), vd = m.pos(b) - m.pos(d);
  const double sc = uc.cross(vc).norm(), cc = uc.dot(vc), sd = ud.cross(vd).norm(), cd = ud.dot(vd);
  const double sine = sc * cd + cc * sd, scale = std::sqrt((sc * sc + cc * cc) * (sd * sd + cd * cd));
  if (sine > 1e-6 * scale) return false;
  if (sine < -1e-6 * scale) return true;
  const double sum = angle_at(m.pos(c), m.pos(a), m.pos(b)) +
                     angle_at(m.pos(d), m.pos(a), m.pos(b));
  return sum > std::numbers::pi + 1e-9;
}

int valence_dev(int v) { return (v - 6) * (v - 6); }

// The flip of a-b to c-d keeps the smaller minimum angle of its two triangles above the floor
// (a key of angle_key), or does not lower it.
bool flip_keeps_angles(const EditMesh& m, int a, int b, int c, int d, double floor_key) {
  const double old_min = std::min(min_angle_key(m.pos(a), m.pos(b), m.pos(c)), min_angle_key(m.pos(b), m.pos(a), m.pos(d)));
  const double new_min = std::min(min_angle_key(m.pos(a), m.pos(d), m.pos(c)), min_angle_key(m.pos(d), m.pos(b), m.pos(c)));
  return new_min >= std::min(old_min, floor_key);
}

// The two triangles at edge a-b and their opposite vertices: (a, b, c) = f1, (b, a, d) = f2.
struct Quad {
  int a, b, c, d, f1, f2;
};
bool quad_at(const EditMesh& m, int a, int b, Quad& q) {
  q.a = a, q.b = b, q.f1 = m.face_with_edge(a, b), q.f2 = m.face_with_edge(b, a);
  if (q.f1 < 0 || q.f2 < 0) return false;
  q.c = m.opposite(q.f1, a, b), q.d = m.opposite(q.f2, b, a);
  return q.c != q.d;
}

// The corner of b whose next vertex is a: the one of the triangle (b, a, d) holding b -> a, or
// null. (The mesh is manifold, so there is at most one.)
const EditMesh::Corner* corner_to(const EditMesh& m, int b, int a) {
  for (const EditMesh::Corner& k : m.corners(b))
    if (k.next == a) return &k;
  return nullptr;
}

// quad_at(m, a, b, q) for an edge a -> b known to be held by triangle f1 with c opposite (a
// corner of a): the same quad, with one search (b's corners) instead of two searches and two
// triangle reads (the defect moves visit every edge around each tried move).
bool quad_with(const EditMesh& m, int a, int b, int f1, int c, Quad& q) {
  const EditMesh::Corner* back = corner_to(m, b, a);
  if (back == nullptr) return false;
  q.a = a, q.b = b, q.f1 = f1, q.c = c, q.f2 = back->f, q.d = back->prev;
  return q.c != q.d;
}

// The two triangles at a listed edge a -> b now and their opposite vertices, as quad_at finds
// them but with c == d allowed (the callers' own tests refuse such a pair): the listed triangle
// if it lives (triangles never change, so it still holds a -> b), else a search.
bool listed_quad(const EditMesh& m, const ListedEdge& e, Quad& q) {
  if (m.tri_alive(e.f)) {
    q.f1 = e.f, q.c = m.tri(e.f)[(e.k + 2) % 3];
  } else {
    q.f1 = m.face_with_edge(e.a, e.b);
    if (q.f1 < 0) return false;
    q.c = m.opposite(q.f1, e.a, e.b);
  }
  const EditMesh::Corner* back = corner_to(m, e.b, e.a);
  if (back == nullptr) return false;
  q.a = e.a, q.b = e.b, q.f2 = back->f, q.d = back->prev;
  return true;
}

// The best second flip after a virtual flip of quad `q` (a-b to c-d, not made): among the
// edges at a, b, c and d, the one whose flip, in the mesh after the first, lowers sum
// (valence - 6)^2 most. Returns its gain (0: none) and the edge in `x`, `w`.
int best_second_flip(const EditMesh& m, const Quad& q, int& x, int& w) {
  auto delta = [&](int v) { return v == q.a || v == q.b ? -1 : (v == q.c || v == q.d ? 1 : 0); };
  auto val = [&](int v) { return m.valence(v) + delta(v); };
  // After the first flip, an edge of f1 (other than a-b) has d opposite it, one of f2 has c.
  // (A corner's prev vertex is the one opposite its edge u -> next in its triangle.)
  auto opp = [&](int f, int prev) { return f == q.f1 ? q.d : (f == q.f2 ? q.c : prev); };
  int best = 0;
  for (int u : {q.a, q.b, q.c, q.d})
    for (const EditMesh::Corner& corner : m.corners(u)) {
      const int v = corner.next;
      if ((u == q.a && v == q.b) || (u == q.b && v == q.a)) continue;
      const EditMesh::Corner* back = corner_to(m, v, u);  // the triangle (v, u, r)
      if (back == nullptr) continue;
      const int p = opp(corner.f, corner.prev), r = opp(back->f, back->prev);
      if (p == r || val(u) <= 3 || val(v) <= 3) continue;
      const int before = valence_dev(val(u)) + valence_dev(val(v)) + valence_dev(val(p)) + valence_dev(val(r));
      const int after = valence_dev(val(u) - 1) + valence_dev(val(v) - 1) + valence_dev(val(p) + 1) + valence_dev(val(r) + 1);
      // The edge searches last, for the flips that would beat the best so far (most do not).
      if (before - after <= best || m.has_edge(p, r) || (p == q.c && r == q.d) || (p == q.d && r == q.c)) continue;
      best = before - after, x = u, w = v;
    }
  return best;
}

}  // namespace

namespace remesh_detail {

// Edge flips until every edge is locally Delaunay (or every remaining violation is rejected).
// A flipped edge's four outer edges are queued again. Returns the number of rejected flips.
int delaunay_by_flips(EditMesh& m, double cos_max_dihedral) {
  std::vector<ListedEdge> stack;
  stack.reserve(m.num_triangle_slots() * 3 / 2);
  all_edges(m, stack);
  std::reverse(stack.begin(), stack.end());
  int rejected = 0;
  int64_t budget = 20 * static_cast<int64_t>(stack.size()) + 100;
  while (!stack.empty() && budget-- > 0) {
    const ListedEdge e = stack.back();
    stack.pop_back();
    Quad q;
    if (!listed_quad(m, e, q)) continue;
    const int a = q.a, b = q.b, c = q.c, d = q.d, f1 = q.f1, f2 = q.f2;
    if (!is_delaunay_violation(m, a, b, c, d)) continue;
    const FlipResult r = try_flip(m, a, b, f1, f2, c, d, cos_max_dihedral);
    if (r == FlipResult::kRejected) ++rejected;
    if (r != FlipResult::kFlipped) continue;
    // The new triangles (a, d, c) and (d, b, c) are the last two.
    const int t3 = m.num_triangle_slots() - 2, t4 = t3 + 1;
    stack.push_back({a, d, t3, 0});
    stack.push_back({d, b, t4, 0});
    stack.push_back({b, c, t4, 1});
    stack.push_back({c, a, t3, 2});
  }
  return rejected;
}

}  // namespace remesh_detail

namespace {

// The flip of quad q if it keeps the angle floor and try_flip accepts it (recorded in `record`
// for EditMesh::undo_flip). Counts try_flip's rejections in `rejected`.
bool checked_flip(EditMesh& m, const Quad& q, double cos_max_dihedral, double floor_key, EditMesh::FlipRecord& record,
                  int& rejected) {
  if (!flip_keeps_angles(m, q.a, q.b, q.c, q.d, floor_key)) return false;
  const FlipResult r = try_flip(m, q.a, q.b, q.f1, q.f2, q.c, q.d, cos_max_dihedral, &record);
  rejected += r == FlipResult::kRejected;
  return r == FlipResult::kFlipped;
}

// The defect moves' memo (EditMesh::regularization_memo): a move tried from an edge and
// undone is tried again only once something near the edge has changed. A try reads the corner
// lists (so valences and edges) and the positions of the vertices within two edges of the quad's
// four vertices, and nothing else where try_flip looks at nothing but the quad (optimistic mode,
// remesh/pass.h: no search for crossings); its flips are undone bit for bit
// (EditMesh::undo_flip). So while none of those vertices has changed (EditMesh::changed_at),
// the try would fail again with the same rejections: it is skipped and its rejections counted
// again. An edit that changes which vertices are within two edges of the quad changes one that
// stays within them (the first of the quad's vertices on a shortest path), so it is seen.
// Whether none of the four vertices changed after `since` (what a flip's valences, angles and
// edge test read: the memo's checks of an edge that was not neutral or was refused).
bool unchanged_since(const EditMesh& m, int a, int b, int c, int d, int64_t since) {
  return std::max({m.changed_at(a), m.changed_at(b), m.changed_at(c), m.changed_at(d)}) <= since;
}

bool changed_near(const EditMesh& m, const Quad& q, int64_t since) {
  for (int u : {q.a, q.b, q.c, q.d}) {
    if (m.changed_at(u) > since) return true;
    for (const EditMesh::Corner& k : m.corners(u)) {
      if (m.changed_at(k.next) > since) return true;
      for (const EditMesh::Corner& l : m.corners(k.next))
        if (m.changed_at(l.next) > since) return true;
    }
  }
  return false;
}

// Whether the flip of q leaves sum (valence - 6)^2 over its four vertices as it was, with a
// defect among them (the flip moves a defect).
bool is_neutral_move(const EditMesh& m, const Quad& q) {
  const int va = m.valence(q.a), vb = m.valence(q.b), vc = m.valence(q.c), vd = m.valence(q.d);
  const int before = valence_dev(va) + valence_dev(vb) + valence_dev(vc) + valence_dev(vd);
  return before > 0 && before == valence_dev(va - 1) + valence_dev(vb - 1) + valence_dev(vc + 1) + valence_dev(vd + 1);
}

// A neutral flip of q (not yet made), then a second flip that lowers the sum (the best one,
// best_second_flip), or if that fails, a second neutral flip at the first's four vertices and
// then such a third. All kept, or all undone. Returns true if kept.
// The flips undone leave the mesh as it was.
bool move_defect(EditMesh& m, const Quad& q, double cos_max_dihedral, double floor_key, int& rejected) {
  // The first flip's angle test (checked_flip's first) before the search for a second flip:
  // about half the candidates fail it (lung phantom).
  if (!flip_keeps_angles(m, q.a, q.b, q.c, q.d, floor_key)) return false;
  int x = -1, w = -1;
  const bool second = best_second_flip(m, q, x, w) > 0;
  EditMesh::FlipRecord first, then, last;
  if (!checked_flip(m, q, cos_max_dihedral, floor_key, first, rejected)) return false;
  Quad q2;
  if (second && quad_at(m, x, w, q2) && checked_flip(m, q2, cos_max_dihedral, floor_key, then, rejected)) return true;
  // (Corners re-read each time: the flips and undos below edit u's list.)
  for (int u : {q.a, q.b, q.c, q.d})
    for (size_t k = 0; k < m.corners(u).size(); ++k) {
      const EditMesh::Corner corner = m.corners(u)[k];
      Quad q3;
      if (!quad_with(m, u, corner.next, corner.f, corner.prev, q2) || !is_neutral_move(m, q2) ||
          best_second_flip(m, q2, x, w) == 0)
        continue;
      if (!checked_flip(m, q2, cos_max_dihedral, floor_key, then, rejected)) continue;
      if (quad_at(m, x, w, q3) && checked_flip(m, q3, cos_max_dihedral, floor_key, last, rejected)) return true;
      m.undo_flip(then);
    }
  m.undo_flip(first);
  return false;
}

// Moves of defects (our addition): a flip that leaves sum (valence - 6)^2 over its four
// vertices as it was moves a 5-7 pair by one edge, which the greedy flips never do, so that
// pairs a few edges apart stay. Such a flip is made when a second flip at its vertices (or a
// second neutral one and a third) then lowers the sum: the pair meets another defect and
// cancels. Every kept move lowers the sum, so repeating them ends. The flips keep the angle
// floor of the greedy ones. Returns the number of moves made; counts the flips try_flip
// rejected in `rejected`.
// With a memo, a move that failed from a listed edge is not tried again while nothing near the
// edge changed (changed_near), and an edge whose flip was not neutral is not looked at again
// while none of its four vertices changed (neutrality is a function of their valences): the same
// moves and rejections as trying every one.
int defect_moves(EditMesh& m, double cos_max_dihedral, double floor_key, std::vector<ListedEdge>& edges,
                 int& rejected, EditMesh::RegularizationMemo* memo) {
  int moves = 0;
  all_edges(m, edges);
  const size_t keys = 3 * static_cast<size_t>(m.num_triangle_slots());
  if (memo && memo->failed_at.size() < keys) {
    memo->failed_at.resize(keys, 0), memo->rejections.resize(keys, 0);
    memo->plain_at.resize(keys, 0), memo->fourth.resize(keys, -1);
  }
  for (const ListedEdge& e : edges) {
    // The key names this edge while its listed triangle lives (a slot named by a key is never
    // given to another triangle: only the slots of undone flips are, and those were never listed).
    const size_t key = 3 * static_cast<size_t>(e.f) + e.k;
    if (memo && memo->plain_at[key] > 0 && m.tri_alive(e.f)) {
      if (unchanged_since(m, e.a, e.b, m.tri(e.f)[(e.k + 2) % 3], memo->fourth[key], memo->plain_at[key])) continue;
    }
    Quad q;
    if (!listed_quad(m, e, q) || q.c == q.d) continue;
    const bool keyed = memo && q.f1 == e.f;
    if (!is_neutral_move(m, q)) {
      if (keyed) memo->plain_at[key] = m.edit_clock(), memo->fourth[key] = q.d;
      continue;
    }
    if (keyed && memo->failed_at[key] > 0 && !changed_near(m, q, memo->failed_at[key])) {
      rejected += memo->rejections[key];
      continue;
    }
    const int before = rejected;
    if (move_defect(m, q, cos_max_dihedral, floor_key, rejected)) {
      ++moves;
    } else if (keyed) {
      memo->failed_at[key] = m.edit_clock();
      memo->rejections[key] = rejected - before;
    }
  }
  return moves;
}

// Valence-driven flips (a regularity step in the spirit of §5.2): flip a-b to c-d when that
// lowers sum (valence - 6)^2 over a, b, c, d and the smaller minimum angle of the two
// triangles stays above the floor (or does not drop). Sweeps until nothing changes (max 5).
int greedy_valence_flips(EditMesh& m, double cos_max_dihedral, double min_angle_rad, bool reuse_refusals,
                         EditMesh::RegularizationMemo* memo) {
  int rejected = 0;
  const double min_floor = angle_key(min_angle_rad);
  // An edge turned down on local grounds (valences, angles, topology: not by try_flip's
  // geometric checks, which may see the rest of the mesh) is turned down again while the
  // triangle it was listed with lives and none of its four vertices changed (corners or
  // position, EditMesh::changed_at) since: then its other triangle, and so its fourth vertex,
  // are the same. A refusal records the mesh's edit_clock() and the fourth vertex d: in the memo
  // kept with the mesh through an optimistic run's stages when there is one, else
  // for this call.
  std::vector<int64_t> own_refused;  // per listed edge 3 f + k: when, or 0
  std::vector<int> own_refused_d;
  std::vector<int64_t>& refused = memo ? memo->refused_at : own_refused;
  std::vector<int>& refused_d = memo ? memo->refused_fourth : own_refused_d;
  std::vector<ListedEdge> edges;
  // Room for the slots that the sweeps' flips add (two per flip), so that these buffers are
  // rarely regrown (each regrowth of a buffer this size faults in fresh pages).
  const size_t room = m.num_triangle_slots() + m.num_triangle_slots() / 4;
  refused.reserve(3 * room);
  refused_d.reserve(3 * room);
  edges.reserve(3 * room / 2);
  for (int sweep = 0; sweep < 5; ++sweep) {
    int flips = 0;
    refused.resize(3 * static_cast<size_t>(m.num_triangle_slots()), 0);
    refused_d.resize(refused.size(), -1);
    all_edges(m, edges);
    for (const ListedEdge& e : edges) {
      const int a = e.a, b = e.b;
      const size_t key = 3 * static_cast<size_t>(e.f) + e.k;
      if (reuse_refusals && refused[key] > 0 && m.tri_alive(e.f)) {
        if (unchanged_since(m, a, b, m.tri(e.f)[(e.k + 2) % 3], refused_d[key], refused[key])) continue;
      }
      Quad q;
      if (!listed_quad(m, e, q)) continue;
      const int f1 = q.f1, f2 = q.f2, c = q.c, d = q.d;
      const bool listed = f1 == e.f;
      auto refuse = [&] {
        if (listed) refused[key] = m.edit_clock(), refused_d[key] = d;
      };
      const int va = m.valence(a), vb = m.valence(b), vc = m.valence(c), vd = m.valence(d);
      const int before = valence_dev(va) + valence_dev(vb) + valence_dev(vc) + valence_dev(vd);
      const int after = valence_dev(va - 1) + valence_dev(vb - 1) + valence_dev(vc + 1) + valence_dev(vd + 1);
      if (after >= before || !flip_keeps_angles(m, a, b, c, d, min_floor)) {
        refuse();
        continue;
      }
      const FlipResult r = try_flip(m, a, b, f1, f2, c, d, cos_max_dihedral);
      if (r == FlipResult::kRejected) ++rejected;
      if (r == FlipResult::kTopology) refuse();
      flips += r == FlipResult::kFlipped;
    }
    if (flips == 0) break;
  }
  return rejected;
}

}  // namespace

namespace remesh_detail {

// Greedy flips, then defect moves (see there) while they find any.
int regularize_valences(EditMesh& m, double cos_max_dihedral, double min_angle_rad, bool reuse_refusals) {
  // The memo of failed defect moves, with the mesh through an optimistic run's stages, for
  // these floors (a call with others starts it anew).
  EditMesh::RegularizationMemo* memo = nullptr;
  if (reuse_refusals && m.optimistic()) {
    memo = &m.regularization_memo();
    const double floor_key = angle_key(min_angle_rad);
    if (memo->cos_max_dihedral != cos_max_dihedral || memo->floor_key != floor_key)
      *memo = {cos_max_dihedral, floor_key, {}, {}, {}, {}, {}, {}};
  }
  int rejected = greedy_valence_flips(m, cos_max_dihedral, min_angle_rad, reuse_refusals, memo);
  // Then up to three rounds of defect moves, each followed by greedy flips again (measured on
  // tests/remesh/clean_mesh_test.cpp: the first round makes most of the gain).
  std::vector<ListedEdge> edges;
  for (int round = 0; round < 3; ++round) {
    if (defect_moves(m, cos_max_dihedral, angle_key(min_angle_rad), edges, rejected, memo) == 0) break;
    rejected += greedy_valence_flips(m, cos_max_dihedral, min_angle_rad, reuse_refusals, memo);
  }
  return rejected;
}

}  // namespace remesh_detail

RemeshReport DelaunayRemesher::run(EditMesh& m, const RemeshContext<3>&) {
  RemeshReport report{"delaunay", 0, 0, 0};
  const double cos_dihedral = std::cos(options_.max_dihedral_deg * std::numbers::pi / 180);
  using remesh_detail::delaunay_by_flips, remesh_detail::regularize_valences;
  if (options_.method == DelaunayMethod::kPlanar) report.rejected_edits += remesh_detail::planar_delaunay(m, cos_dihedral);
  // The planar pass leaves patch seams as they were; flips finish them (and are the whole job
  // for the "flips" method).
  report.rejected_edits += delaunay_by_flips(m, cos_dihedral);
  if (options_.regularize)
    report.rejected_edits +=
        regularize_valences(m, cos_dihedral, options_.min_angle_deg * std::numbers::pi / 180, reuse_refusals_);
  return report;
}

}  // namespace dsnake
