#include "remesh/uniform.h"

#include "framework/mesh/edit_mesh.h"
#include "framework/geometry/triangle_measures.h"
#include "remesh/stage_steps.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

namespace dsnake {

namespace {


// A move may lower the smallest angle of its fan only while it stays above 15 degrees (so that
// relaxation never creates slivers on strongly curved parts, where the surface map distorts).
constexpr double kMinAngleFloor = 15 * std::numbers::pi / 180;

// §5.1 for one vertex v with ordered ring r: the ring goes to the unit circle at angles
// proportional to arc length, v to the mean-value combination of the ring's images
// [Floater 2003], and the circle's centre is located in the image fan (v', r_i', r_i+1') and
// mapped back to (v, r_i, r_i+1) with the same barycentric coordinates.
// Per-thread scratch of relaxed_position (no allocation per vertex once grown).
struct RelaxScratch {
  std::vector<double> s, tan_half, len;
  std::vector<Eigen::Vector2d> u;
};

std::optional<Point<3>> relaxed_position(const EditMesh& m, int v, const std::vector<int>& r, RelaxScratch& scratch) {
  const int k = static_cast<int>(r.size());
  if (k < 3) return std::nullopt;
  const Point<3>& x = m.pos(v);
  auto& s = scratch.s;
  s.assign(k + 1, 0.0);
  for (int i = 0; i < k; ++i) s[i + 1] = s[i] + (m.pos(r[(i + 1) % k]) - m.pos(r[i])).norm();
  if (!(s[k] > 0)) return std::nullopt;
  auto& u = scratch.u;
  u.resize(k);
  for (int i = 0; i < k; ++i) {
    const double th = 2 * std::numbers::pi * s[i] / s[k];
    u[i] = {std::cos(th), std::sin(th)};
  }
  // Mean-value weights: w_i = (tan(a_{i-1}/2) + tan(a_i/2)) / |r_i - v|, a_i = angle(r_i, v, r_i+1),
  // with tan(a/2) = |e x f| / (|e| |f| + e . f) for the edges e, f from v (no trigonometry; the
  // denominator kept off 0 for a flat angle, where the weight becomes very large instead).
  auto& tan_half = scratch.tan_half;
  auto& len = scratch.len;
  tan_half.resize(k);
  len.resize(k);
  for (int i = 0; i < k; ++i) {
    len[i] = (m.pos(r[i]) - x).norm();
    if (!(len[i] > 0)) return std::nullopt;
  }
  for (int i = 0; i < k; ++i) {
    const Point<3> e = m.pos(r[i]) - x, f = m.pos(r[(i + 1) % k]) - x;
    const double lengths = len[i] * len[(i + 1) % k];
    tan_half[i] = e.cross(f).norm() / std::max(lengths + e.dot(f), 1e-16 * lengths);
  }
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
  double wsum = 0;
  for (int i = 0; i < k; ++i) {
    const double w = (tan_half[(i + k - 1) % k] + tan_half[i]) / len[i];
    uv += w * u[i];
    wsum += w;
  }
  if (!(wsum > 0)) return std::nullopt;
  uv /= wsum;
  // Locate the centre (0, 0) in the fan of image triangles (uv, u_i, u_i+1).
  for (int i = 0; i < k; ++i) {
    const Eigen::Vector2d& a = uv;
    const Eigen::Vector2d& b = u[i];
    const Eigen::Vector2d& c = u[(i + 1) % k];
    const double det = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (std::abs(det) < 1e-14) continue;
    const Eigen::Vector2d p = -a;
    const double lb = (p.x() * (c - a).y() - p.y() * (c - a).x()) / det;
    const double lc = ((b - a).x() * p.y() - (b - a).y() * p.x()) / det;
    const double la = 1 - lb - lc;
    constexpr double kEps = -1e-12;
    if (la >= kEps && lb >= kEps && lc >= kEps) return la * x + lb * m.pos(r[i]) + lc * m.pos(r[(i + 1) % k]);
  }
  return std::nullopt;
}

// Commits the move of free vertex v to `to` unless it turns a fan triangle's normal by more
// than acos(cos_max), lowers the fan's smallest angle below min(its old value, the floor), or
// makes the fan cross the surface. `fan`, `fan_tris`: scratch.
bool commit_move(EditMesh& m, int v, const Point<3>& to, double cos_max, std::vector<int>& fan,
                 std::vector<Triangle>& fan_tris) {
  static const double floor_key = angle_key(kMinAngleFloor);
  m.triangles_of(v, fan);
  if (fan.size() > 32) return true;  // valence > 32: beyond the batched check, left alone
  // The move may turn no triangle by more than the limit, and may lower the fan's smallest
  // angle only while it stays above the floor (the old angles are needed only below it).
  auto at = [&](int x) -> const Point<3>& { return x == v ? to : m.pos(x); };
  bool ok = true;
  double new_min = 1;  // the key of the largest angle
  for (size_t i = 0; i < fan.size() && ok; ++i) {
    const auto& t = m.tri(fan[i]);
    const Point<3> nn = area_normal(at(t[0]), at(t[1]), at(t[2]));
    ok = nn.squaredNorm() > 0 &&
         cos_between(nn, area_normal(m.pos(t[0]), m.pos(t[1]), m.pos(t[2]))) >= cos_max;
    new_min = std::min(new_min, min_angle_key(at(t[0]), at(t[1]), at(t[2])));
  }
  if (ok && new_min < floor_key) {
    double old_min = floor_key;
    for (int f : fan) {
      const auto& t = m.tri(f);
      old_min = std::min(old_min, min_angle_key(m.pos(t[0]), m.pos(t[1]), m.pos(t[2])));
    }
    ok = new_min >= old_min;
  }
  const Point<3> old = m.pos(v);
  if (ok) {
    m.set_pos(v, to);  // tentative: the crossing test reads the positions
    fan_tris.clear();
    for (int f : fan) fan_tris.push_back(m.tri(f));
    ok = !m.intersects_any(fan_tris, fan);
  }
  m.set_pos(v, old);
  if (ok) m.move_vertex(v, to);  // the intersection grid sees the new boxes
  return ok;
}

}  // namespace

namespace remesh_detail {

int relax_sweep(EditMesh& m, double cos_max) {
  const int n = m.num_vertices();
  const double mean_edge = m.mean_edge_length();  // of the mesh as the calling stage received it
  std::vector<std::optional<Point<3>>> proposal(n);
  // Proposals from the positions at the start of the sweep (thread-count independent).
#pragma omp parallel if (n >= 256)
  {
    std::vector<int> ring;
    RelaxScratch scratch;
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v) {
      if (!m.is_free(v) || !m.vertex_alive(v)) continue;
      m.ring(v, ring);
      proposal[v] = relaxed_position(m, v, ring, scratch);
    }
  }
  // Serial commit in vertex order, each move checked against the current mesh.
  std::vector<Triangle> fan_tris;
  std::vector<int> fan;
  int rejected = 0;
  for (int v = 0; v < n; ++v) {
    if (!proposal[v]) continue;
    // Moves below 1% of the mean edge are not worth their checks (the relaxation has converged).
    if ((*proposal[v] - m.pos(v)).squaredNorm() < 1e-4 * mean_edge * mean_edge) continue;
    rejected += !commit_move(m, v, *proposal[v], cos_max, fan, fan_tris);
  }
  return rejected;
}

}  // namespace remesh_detail

RemeshReport UniformRemesher::run(EditMesh& m, const RemeshContext<3>&) {
  RemeshReport report{"uniform", 0, 0, 0};
  const double cos_max = std::cos(options_.max_normal_change_deg * std::numbers::pi / 180);
  for (int sweep = 0; sweep < options_.iterations; ++sweep) report.rejected_edits += remesh_detail::relax_sweep(m, cos_max);
  return report;
}

}  // namespace dsnake
