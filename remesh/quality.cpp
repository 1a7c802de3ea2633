#include "remesh/quality.h"

#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace dsnake {

// Valences from the connectivity's one-rings, angles from the triangles' corners, and edge
// lengths over each undirected edge once. Serial: exact counts, thread-count independent.
MeshQuality compute_mesh_quality(const Snake<3>& snake, int bins) {
  DSNAKE_ASSERT(bins >= 1, "histogram needs at least one bin");
  MeshQuality q;
  const auto& c = snake.connectivity();
  const auto& p = snake.positions();
  q.vertices = snake.num_vertices();
  q.triangles = static_cast<int>(c.triangles().size());
  q.closed = c.closed_manifold_problem().empty();
  q.euler_characteristic = c.euler_characteristic();
  int regular = 0;
  for (int v = 0; v < q.vertices; ++v) regular += c.neighbors(v).size() == 6;
  q.valence6_share = q.vertices > 0 ? double(regular) / q.vertices : 0.0;
  double smallest = std::numbers::pi;
  int good = 0;
  for (const auto& t : c.triangles()) {
    double tmin = std::numbers::pi;
    for (int k = 0; k < 3; ++k) {
      const Point<3> u = p[t[(k + 1) % 3]] - p[t[k]], w = p[t[(k + 2) % 3]] - p[t[k]];
      tmin = std::min(tmin, std::atan2(u.cross(w).norm(), u.dot(w)));
    }
    smallest = std::min(smallest, tmin);
    good += tmin * 180 / std::numbers::pi >= 20.0;
  }
  q.min_angle_deg = q.triangles > 0 ? smallest * 180 / std::numbers::pi : 0.0;
  q.share_min_angle_ge_20 = q.triangles > 0 ? double(good) / q.triangles : 0.0;
  const auto edges = c.edges();
  std::vector<double> len(edges.size());
  for (size_t e = 0; e < edges.size(); ++e) len[e] = (p[edges[e][0]] - p[edges[e][1]]).norm();
  q.edge_histogram.assign(bins, 0);
  if (!len.empty()) {
    q.edge_min = *std::min_element(len.begin(), len.end());
    q.edge_max = *std::max_element(len.begin(), len.end());
    double sum = 0;
    for (double l : len) sum += l;
    q.edge_mean = sum / len.size();
    const double width = (q.edge_max - q.edge_min) / bins;
    for (double l : len) {
      const int b = width > 0 ? std::min(bins - 1, static_cast<int>((l - q.edge_min) / width)) : 0;
      ++q.edge_histogram[b];
    }
  }
  return q;
}

void to_json(nlohmann::json& j, const MeshQuality& q) {
  j = {{"vertices", q.vertices},
       {"triangles", q.triangles},
       {"valence6_share", q.valence6_share},
       {"min_angle_deg", q.min_angle_deg},
       {"share_min_angle_ge_20", q.share_min_angle_ge_20},
       {"euler_characteristic", q.euler_characteristic},
       {"closed", q.closed},
       {"edge_length", {{"min", q.edge_min}, {"mean", q.edge_mean}, {"max", q.edge_max},
                        {"histogram", q.edge_histogram}}}};
}

}  // namespace dsnake
