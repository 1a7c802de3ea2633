#include "remesh/refine.h"

#include "framework/mesh/edit_mesh.h"
#include "framework/geometry/triangle_measures.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace dsnake {

double refine_threshold(const RefineOptions& o, int phase_iteration, int phase_iterations) {
  const double start = o.start_max_edge > 0 ? o.start_max_edge : o.max_edge;
  if (start <= o.max_edge || phase_iterations <= 0 || o.ramp <= 0) return o.max_edge;
  const double s = std::clamp(phase_iteration / (o.ramp * phase_iterations), 0.0, 1.0);
  return start * std::pow(o.max_edge / start, s);
}

// One pass over the triangles present at the start: split 1 -> 3 at the barycentre (§5.3).
// The three new triangles tile the old one, so a split never creates a self-intersection and
// needs no check; connectivity around deformation vertices changes, their positions do not.
// Our one addition: when a 1 -> 3 split would leave a sliver (a sub-triangle angle below
// kSliverDeg: the triangle is already thin, typically along a crease whose long edge the
// Delaunay stage may not flip), the longest edge is split at its midpoint instead (2 -> 4),
// which also tiles the two old triangles exactly. Without it, repeated passes split the same
// thin triangles again and again, towards degenerate ones.
RemeshReport RefineRemesher::run(EditMesh& m, const RemeshContext<3>& context) {
  constexpr double kSliverDeg = 15;
  RemeshReport report{"refine", 0, 0, 0};
  const double threshold = refine_threshold(options_, context.phase_iteration, context.phase_iterations);
  const double t2 = threshold * threshold;
  const double sliver = angle_key(kSliverDeg * std::numbers::pi / 180);
  const int slots = m.num_triangle_slots();
  for (int f = 0; f < slots; ++f) {
    if (!m.tri_alive(f)) continue;  // split with a neighbour's edge earlier in this pass
    const Triangle t = m.tri(f);
    double longest = 0;
    int k_long = 0;
    for (int k = 0; k < 3; ++k) {
      const double len2 = (m.pos(t[k]) - m.pos(t[(k + 1) % 3])).squaredNorm();
      if (len2 > longest) { longest = len2; k_long = k; }
    }
    if (longest <= t2) continue;
    if (m.num_live_vertices() >= context.max_vertices) {  // a split adds one vertex
      report.over_budget = true;
      break;
    }
    const Point<3> c = (m.pos(t[0]) + m.pos(t[1]) + m.pos(t[2])) / 3.0;
    double sub_min = 1;  // the key of the largest angle
    for (int k = 0; k < 3; ++k)
      sub_min = std::min(sub_min, min_angle_key(m.pos(t[k]), m.pos(t[(k + 1) % 3]), c));
    if (sub_min >= sliver) {
      const int v = m.add_vertex(c);
      m.remove_triangle(f);
      m.add_triangle({t[0], t[1], v});
      m.add_triangle({t[1], t[2], v});
      m.add_triangle({t[2], t[0], v});
      continue;
    }
    // Edge split of a -> b, shared with the twin triangle (b, a, d).
    const int a = t[k_long], b = t[(k_long + 1) % 3], cv = t[(k_long + 2) % 3];
    const int g = m.face_with_edge(b, a);
    if (g < 0) continue;
    const int d = m.opposite(g, b, a);
    const int v = m.add_vertex(0.5 * (m.pos(a) + m.pos(b)));
    m.remove_triangle(f);
    m.remove_triangle(g);
    m.add_triangle({a, v, cv});
    m.add_triangle({v, b, cv});
    m.add_triangle({b, v, d});
    m.add_triangle({v, a, d});
  }
  return report;
}

}  // namespace dsnake
