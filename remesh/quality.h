// Mesh-quality statistics after remeshing (§5: "a high quality mesh", "almost fully regular"):
// what result.json reports under "mesh_quality" after a remeshing phase in 3D.
#pragma once

#include "framework/core/shape.h"

#include <nlohmann/json_fwd.hpp>
#include <vector>

namespace dsnake {

struct MeshQuality {
  int vertices = 0;
  int triangles = 0;
  double valence6_share = 0;         // share of vertices with exactly 6 neighbours
  double min_angle_deg = 0;          // smallest triangle angle in the mesh, degrees
  double share_min_angle_ge_20 = 0;  // share of triangles whose smallest angle is >= 20 degrees
  int euler_characteristic = 0;      // V - E + F (2 for a sphere, 0 for a torus, 2 - 2g)
  bool closed = false;               // closed, manifold and consistently oriented
  double edge_min = 0, edge_mean = 0, edge_max = 0;  // physical units
  // Edge-length histogram: edge_histogram.size() equal bins over [edge_min, edge_max].
  std::vector<int> edge_histogram;
};

// Statistics of a closed triangle mesh; `bins` histogram bins (>= 1).
MeshQuality compute_mesh_quality(const Snake<3>& snake, int bins = 10);

// {"vertices", "triangles", "valence6_share", "min_angle_deg", "share_min_angle_ge_20",
//  "euler_characteristic", "closed", "edge_length": {"min", "mean", "max", "histogram"}}
void to_json(nlohmann::json& j, const MeshQuality& q);

}  // namespace dsnake
