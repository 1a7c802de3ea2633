#include "remesh/simplify.h"

#include "framework/core/image.h"
#include "framework/mesh/edit_mesh.h"
#include "framework/geometry/triangle_measures.h"
#include "remesh/stage_steps.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

namespace dsnake {

namespace remesh_detail {

// A stable LSD radix sort on the bits of len (a non-negative double's bits order as the double
// does), 11 bits a pass, a pass skipped when all keys agree on its digit: linear, where the
// comparison sort would spend most of its time in mispredicted branches.
void sort_by_length(std::vector<CollapseCandidate>& cand, std::vector<CollapseCandidate>& scratch) {
  constexpr int kBits = 11, kBuckets = 1 << kBits;
  scratch.resize(cand.size());
  std::vector<int> count(kBuckets);
  auto key = [](const CollapseCandidate& c) { return std::bit_cast<uint64_t>(c.len); };
  for (int shift = 0; shift < 64; shift += kBits) {
    std::fill(count.begin(), count.end(), 0);
    for (const CollapseCandidate& c : cand) ++count[(key(c) >> shift) & (kBuckets - 1)];
    if (std::find(count.begin(), count.end(), static_cast<int>(cand.size())) != count.end()) continue;
    for (int i = 0, sum = 0; i < kBuckets; ++i) sum += std::exchange(count[i], sum);
    for (const CollapseCandidate& c : cand) scratch[count[(key(c) >> shift) & (kBuckets - 1)]++] = c;
    cand.swap(scratch);
  }
}

}  // namespace remesh_detail

namespace {


// Distance from point p to triangle (a, b, c) (closest point by region, Ericson's method).
double point_triangle_distance(const Point<3>& p, const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const Point<3> ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return ap.norm();
  const Point<3> bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bp.norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Point<3> cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return cp.norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  const double den = 1 / (va + vb + vc);
  return (p - (a + ab * (vb * den) + ac * (vc * den))).norm();
}

// kRejected: a local safety check (normals, angles, valence); kCrossing: the new triangles
// would cross the surface.
enum class Collapse { kDone, kTopology, kRejected, kCriterion, kCrossing };

// Collapses free vertex a onto its neighbour b. `short_edge`: forced by min_edge (no size or
// error limit); otherwise the collapse must keep every new edge <= max_edge and the surface
// within curvature_ratio * |ab| / 8 of a's old position (kCriterion, tested before the safety
// checks, whose failures count as rejected edits).
Collapse try_collapse(EditMesh& m, int a, int b, bool short_edge, const SimplifyOptions& o, double max_edge,
                      double cos_max, std::vector<int>& fan, std::vector<Triangle>& fresh) {
  const int f1 = m.face_with_edge(a, b), f2 = m.face_with_edge(b, a);
  if (f1 < 0 || f2 < 0) return Collapse::kTopology;
  const int c = m.opposite(f1, a, b), d = m.opposite(f2, b, a);
  // Link condition: a and b share exactly the neighbours c and d (each neighbour once, as a
  // corner's next vertex).
  int common = 0;
  for (const EditMesh::Corner& x : m.corners(a))
    for (const EditMesh::Corner& y : m.corners(b)) common += x.next == y.next;
  if (common != 2 || c == d) return Collapse::kTopology;
  m.triangles_of(a, fan);  // a copy: the removals below edit a's list
  fresh.clear();
  for (int f : fan) {
    if (f == f1 || f == f2) continue;
    Triangle t = m.tri(f);
    for (int& v : t)
      if (v == a) v = b;
    fresh.push_back(t);
  }
  // The size and error criteria first (the cheapest tests that turn most candidates down).
  if (!short_edge) {
    double dist = std::numeric_limits<double>::infinity();
    for (const auto& t : fresh) {
      for (int v : t)
        if (v != b && (m.pos(v) - m.pos(b)).squaredNorm() > max_edge * max_edge) return Collapse::kCriterion;
    }
    for (const auto& t : fresh)
      dist = std::min(dist, point_triangle_distance(m.pos(a), m.pos(t[0]), m.pos(t[1]), m.pos(t[2])));
    if (dist > o.curvature_ratio * (m.pos(a) - m.pos(b)).norm() / 8) return Collapse::kCriterion;
  }
  // No triangle may turn by more than the limit (fan and fresh in the same order).
  for (size_t i = 0, k = 0; i < fan.size(); ++i) {
    if (fan[i] == f1 || fan[i] == f2) continue;
    const Triangle& t = m.tri(fan[i]);
    const Triangle& u = fresh[k++];
    const Point<3> old_n = area_normal(m.pos(t[0]), m.pos(t[1]), m.pos(t[2]));
    const Point<3> n = area_normal(m.pos(u[0]), m.pos(u[1]), m.pos(u[2]));
    if (n.squaredNorm() == 0 || cos_between(n, old_n) < cos_max) return Collapse::kRejected;
  }
  // The collapse may lower the fans' smallest angle only while it stays above 15 degrees.
  // (The fans' old angles are needed only when a new one is below 15 degrees.)
  static const double floor_key = angle_key(15 * std::numbers::pi / 180);
  double fresh_min = 1;
  for (const auto& t : fresh)
    fresh_min = std::min(fresh_min, min_angle_key(m.pos(t[0]), m.pos(t[1]), m.pos(t[2])));
  if (fresh_min < floor_key) {
    double old_min = floor_key;
    for (int g : {a, b})
      for (const EditMesh::Corner& corner : m.corners(g)) {
        const auto& t = m.tri(corner.f);
        old_min = std::min(old_min, min_angle_key(m.pos(t[0]), m.pos(t[1]), m.pos(t[2])));
      }
    if (fresh_min < old_min) return Collapse::kRejected;
  }
  if (fresh.size() > 32) return Collapse::kRejected;  // a vertex of valence > 34: leave it
  if (m.intersects_any(fresh, fan)) return Collapse::kCrossing;
  for (int f : fan) m.remove_triangle(f);
  for (const auto& t : fresh) m.add_triangle(t);
  return Collapse::kDone;
}

// Valence deviation sum (v - 6)^2 over the vertices an a -> b collapse changes, before and after:
// b takes a's neighbours (valence va + vb - 4), the two opposite vertices c and d lose one.
int collapse_valence_gain(const EditMesh& m, int a, int b) {
  const int f1 = m.face_with_edge(a, b), f2 = m.face_with_edge(b, a);
  if (f1 < 0 || f2 < 0) return 0;
  const int c = m.opposite(f1, a, b), d = m.opposite(f2, b, a);
  auto dev = [](int v) { return (v - 6) * (v - 6); };
  const int va = m.valence(a), vb = m.valence(b), vc = m.valence(c), vd = m.valence(d);
  return dev(va) + dev(vb) + dev(vc) + dev(vd) - dev(va + vb - 4) - dev(vc - 1) - dev(vd - 1);
}

// The longest edge an a -> b collapse would create (from b to a's other neighbours).
double longest_new_edge(const EditMesh& m, int a, int b) {
  double longest = 0;
  for (const EditMesh::Corner& c : m.corners(a)) longest = std::max(longest, (m.pos(c.next) - m.pos(b)).squaredNorm());
  return std::sqrt(longest);
}

// One sweep of valence collapses: each free vertex a onto the neighbour b whose collapse lowers
// the valence deviation most (ties: the shorter edge), if no new edge exceeds `limit`; with the
// safety checks of try_collapse. Returns the collapses made; counts rejections in `rejected`.
int valence_collapse_sweep(EditMesh& m, double limit, const SimplifyOptions& o, double cos_max, std::vector<int>& fan,
                           std::vector<Triangle>& fresh, int& rejected) {
  int done = 0;
  for (int a = 0; a < m.num_vertices(); ++a) {
    if (!m.is_free(a) || !m.vertex_alive(a) || m.valence(a) == 6) continue;
    int best = -1, best_gain = 0;
    double best_len = 0;
    for (const EditMesh::Corner& c : m.corners(a)) {
      const int gain = collapse_valence_gain(m, a, c.next);
      const double len = (m.pos(a) - m.pos(c.next)).squaredNorm();
      if (gain > best_gain || (gain == best_gain && gain > 0 && len < best_len)) best = c.next, best_gain = gain, best_len = len;
    }
    if (best < 0 || longest_new_edge(m, a, best) > limit) continue;
    const Collapse r = try_collapse(m, a, best, true, o, limit, cos_max, fan, fresh);
    done += r == Collapse::kDone;
    rejected += r == Collapse::kRejected || r == Collapse::kCrossing;
  }
  return done;
}

}  // namespace

// Regularisation (our addition to §5.4): the flips of the delaunay stage cannot remove a pair of
// valence-5 and valence-7 vertices, only move it, so a flip-regularised mesh keeps about a
// quarter of its vertices irregular; a half-edge collapse that lowers sum (valence - 6)^2 (a
// valence-5 vertex onto a valence-5 or -6 neighbour whose opposite vertices have valence 7, ...)
// removes such defects. Up to three sweeps of valence collapses (no new edge over
// kValenceCollapseEdge mean edges), each followed by the delaunay stage's Delaunay and valence
// flips (which move the remaining defects together). The limit was chosen by measurement on the
// in-loop tests (tests/remesh/clean_mesh_test.cpp, physical internal energy, short collapses
// limited as below): 4/3, the split threshold of isotropic remeshing [Botsch and Kobbelt 2004],
// leaves too few collapses; valence 6 at 1.7 / 2.0 / 2.3 (ellipsoid, torus, genus 2): 78.8 /
// 80.6 / 81.0%, 80.6 / 81.9 / 83.5%, 79.2 / 80.3 / 81.8%; at 3.0 the smallest angle falls
// below 18 degrees on genus 2. Capping these collapses at the refine threshold (so that the next
// refinement cannot split their edges) leaves too few of them: 75-77%.
constexpr double kValenceCollapseEdge = 2.3;

// A collapse of an edge shorter than min_edge makes no edge longer than this many mean edges
// (of the mesh the stage receives). Without a limit, on the genus-2 in-loop test, whose refine
// threshold is twice min_edge, such collapses made edges that the next pass's refinement split
// 1 -> 3 into short edges again: ~1100 splits and ~1100 collapses in every pass of a mesh of
// 2400 vertices, each round leaving new valence defects (valence 6: 64%; with the limit, and
// valence collapses at 2.3 mean edges: 82%). Genus 2 at 1.4 / 1.5 / 1.6 / 1.8 / 2.0: 79.9 /
// 81.8 / 80.5 / 74.1 / 71.4% (ellipsoid 79.3 / 81.0 / 80.3 / 79.9 / 80.1%, torus 84.2 / 83.5 /
// 83.4 / 83.3 / 83.2%).
constexpr double kShortCollapseEdge = 1.5;

int SimplifyRemesher::regularize(EditMesh& m, double mean_edge, double cos_max, std::vector<int>& fan,
                                 std::vector<Triangle>& fresh) const {
  constexpr double kCos30 = 0.86602540378443865, kMinAngle25 = 25 * std::numbers::pi / 180;
  const double limit = kValenceCollapseEdge * mean_edge;
  int rejected = 0;
  for (int sweep = 0; sweep < 3; ++sweep) {
    const int done = valence_collapse_sweep(m, limit, options_, cos_max, fan, fresh, rejected);
    rejected += remesh_detail::delaunay_by_flips(m, kCos30);
    rejected += remesh_detail::regularize_valences(m, kCos30, kMinAngle25, reuse_refusals_);
    if (done == 0) break;
  }
  return rejected;
}

RemeshReport SimplifyRemesher::run(EditMesh& m, const RemeshContext<3>& context) {
  RemeshReport report{"simplify", 0, 0, 0};
  const double voxel = context.image ? context.image->spacing().minCoeff() : 1.0;
  const double min_edge = options_.min_edge > 0 ? options_.min_edge : voxel;
  const double max_edge = options_.max_edge > 0 ? options_.max_edge : 2 * min_edge;
  const double cos_max = std::cos(options_.max_normal_change_deg * std::numbers::pi / 180);
  const double mean_edge = m.mean_edge_length();  // of the mesh as this stage receives it
  const double short_cap = kShortCollapseEdge * mean_edge;
  std::vector<int> fan;
  std::vector<Triangle> fresh;
  // A candidate refused on local grounds (all but a crossing) is refused again, with the same
  // outcome, while the fans of a and b are as they were then: positions never change here, and
  // a collapse stamps the vertices whose fans it changes (those of its new triangles).
  const int n = m.num_vertices();
  int64_t time = 0;
  std::vector<int64_t> stamp(n, 0), refused_at(n, 0);
  std::vector<int> refused_b(n, -1);
  std::vector<Collapse> refused_as(n, Collapse::kDone);
  // Candidates: each free vertex with its shortest edge, shortest first (ties by index).
  std::vector<remesh_detail::CollapseCandidate> cand, scratch;
  for (int pass = 0; pass < 3; ++pass) {
    cand.clear();
    for (int a = 0; a < m.num_vertices(); ++a) {
      if (!m.is_free(a) || !m.vertex_alive(a)) continue;
      // Each neighbour once, as a corner's next vertex; squared lengths (one root at the end).
      int best = -1;
      double best_len2 = std::numeric_limits<double>::infinity();
      for (const EditMesh::Corner& c : m.corners(a)) {
        const double len2 = (m.pos(a) - m.pos(c.next)).squaredNorm();
        if (len2 < best_len2) { best_len2 = len2; best = c.next; }
      }
      const double best_len = std::sqrt(best_len2);
      if (best >= 0 && (best_len < min_edge || (options_.curvature_ratio > 0 && best_len < max_edge)))
        cand.push_back({best_len, a, best});
    }
    remesh_detail::sort_by_length(cand, scratch);
    int done = 0;
    for (const auto& [len, a, b] : cand) {
      if (!m.vertex_alive(a) || !m.vertex_alive(b) || !m.has_edge(a, b)) continue;
      if (reuse_refusals_ && refused_b[a] == b && std::max(stamp[a], stamp[b]) < refused_at[a]) {
        if (refused_as[a] == Collapse::kRejected) ++report.rejected_edits;
        continue;
      }
      const double now = (m.pos(a) - m.pos(b)).norm();
      // (A short edge whose collapse would make an edge over kShortCollapseEdge mean edges is
      // left, see there.)
      if (now < min_edge && longest_new_edge(m, a, b) > short_cap) continue;
      const Collapse r = try_collapse(m, a, b, now < min_edge, options_, max_edge, cos_max, fan, fresh);
      if (r == Collapse::kDone) {
        ++done, ++time;
        for (const Triangle& t : fresh)
          for (int v : t) stamp[v] = time;
      } else if (r != Collapse::kCrossing) {
        refused_at[a] = time + 1, refused_b[a] = b, refused_as[a] = r;
      }
      if (r == Collapse::kRejected || r == Collapse::kCrossing) ++report.rejected_edits;
    }
    if (done == 0) break;
  }
  if (options_.regularize) report.rejected_edits += regularize(m, mean_edge, cos_max, fan, fresh);
  if (options_.relax) report.rejected_edits += remesh_detail::relax_sweep(m, cos_max);
  return report;
}

}  // namespace dsnake
