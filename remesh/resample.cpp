#include "remesh/resample.h"

#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {

// The number of edges a span of arc length `length` between two anchors is resampled into, as a
// double: length / max_edge may exceed int's range (a budget check before any cast).
double span_edges(double length, const ResampleOptions& o, bool lone_anchor) {
  double m = std::max(1.0, std::ceil(length / o.max_edge - 1e-12));
  if (length / m < o.min_edge) m = std::max(1.0, std::floor(length / o.min_edge));
  if (lone_anchor) m = std::max(m, 3.0);  // a lone anchor still needs a polygon
  return m;
}

}  // namespace

RemeshReport ResampleRemesher::apply(Snake<2>& snake, const RemeshContext<2>& context) {
  RemeshReport report{"resample", snake.num_vertices(), snake.num_vertices(), 0};
  const auto& q = snake.positions();
  const int n = snake.num_vertices();
  bool fits = true;
  for (int v = 0; v < n && fits; ++v) {
    const double len = (q[(v + 1) % n] - q[v]).norm();
    constexpr double kSlack = 1e-9;  // resampled edges land exactly on the bounds
    fits = len <= options_.max_edge * (1 + kSlack) && (len >= options_.min_edge * (1 - kSlack) ||
                                        (snake.is_deformation_vertex(v) && snake.is_deformation_vertex((v + 1) % n)));
  }
  if (fits) return report;

  // Anchors: the deformation vertices, or vertex 0 when there are none.
  std::vector<int> anchors;
  for (int v = 0; v < n; ++v)
    if (snake.is_deformation_vertex(v)) anchors.push_back(v);
  if (anchors.empty()) anchors.push_back(0);

  // Each span's edge count first, so that a resampling past the vertex budget allocates nothing.
  std::vector<int> edges(anchors.size());
  double total = 0;
  for (size_t a = 0; a < anchors.size(); ++a) {
    const int from = anchors[a];
    const int to = anchors[(a + 1) % anchors.size()];
    const int count = (to - from + n - 1) % n + 1;  // edges from `from` to `to` (a full loop if equal)
    double length = 0;
    for (int k = 0; k < count; ++k) length += (q[(from + k + 1) % n] - q[(from + k) % n]).norm();
    const double m = span_edges(length, options_, from == to);
    total += m;
    if (!(total <= context.max_vertices)) {
      report.over_budget = true;
      return report;
    }
    edges[a] = static_cast<int>(m);
  }

  PointList<2> out;
  std::vector<int> ids;
  out.reserve(size_t(total));
  ids.reserve(size_t(total));
  std::vector<double> s;
  for (size_t a = 0; a < anchors.size(); ++a) {
    const int from = anchors[a];
    const int to = anchors[(a + 1) % anchors.size()];
    const int count = (to - from + n - 1) % n + 1;
    // Arc length along the current polyline from `from` to `to`.
    s.assign(count + 1, 0.0);
    for (int k = 0; k < count; ++k) s[k + 1] = s[k] + (q[(from + k + 1) % n] - q[(from + k) % n]).norm();
    const double length = s[count];
    const int m = edges[a];
    out.push_back(q[from]);
    ids.push_back(snake.template_id(from));
    int seg = 0;
    for (int j = 1; j < m; ++j) {
      const double target = length * j / m;
      while (seg < count - 1 && s[seg + 1] < target) ++seg;
      const double span = s[seg + 1] - s[seg];
      const double t = span > 0 ? (target - s[seg]) / span : 0.0;
      out.push_back((1 - t) * q[(from + seg) % n] + t * q[(from + seg + 1) % n]);
      ids.push_back(-1);
    }
  }
  const int count = static_cast<int>(out.size());
  snake.set_topology(std::move(out), Connectivity::polygon(count), std::move(ids));
  report.vertices_after = count;
  return report;
}

}  // namespace dsnake
