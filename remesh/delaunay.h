// §5.2 mesh connectivity: make the triangulation Delaunay, for regular connectivity and
// near-equilateral triangles. Two methods:
//  - "planar" (the paper's): split the mesh into disc patches (recursive BFS halving, so any
//    genus works), parameterise each patch with mean-value coordinates [Floater 2003], the
//    boundary on a circle (one sparse solve per patch), triangulate the parameter points with
//    a planar Delaunay triangulation (OpenCV Subdiv2D) and adopt that connectivity in 3D;
//  - "flips": intrinsic Delaunay by edge flips: flip every edge whose two opposite angles sum
//    to more than pi, until none is left (simpler, no parameterisation).
// Either way no vertex moves; a flip or a patch whose new triangles would fold (dihedral over
// max_dihedral_deg), flip a normal, or cross the surface is rejected and left as it was.
// "regularize" then flips edges that bring vertex valences closer to 6 without lowering the
// smaller of the two triangles' minimum angles below min_angle_deg.
#pragma once

#include "framework/json_reader.h"
#include "framework/remesher.h"
#include "remesh/pass.h"

#include <memory>
#include <string>

namespace dsnake {

struct DelaunayOptions {
  std::string method = "flips";  // "flips" or "planar"
  double max_dihedral_deg = 30;  // largest bend across an edge that a flip may straighten
  bool regularize = true;        // valence-driven flips after the Delaunay pass
  double min_angle_deg = 25;     // floor on triangle angles for the valence flips
};

class DelaunayRemesher : public EditStage {
 public:
  explicit DelaunayRemesher(DelaunayOptions options) : options_(options) {}
  std::string type() const override { return "delaunay"; }
  RemeshReport run(remesh_detail::EditMesh& m, const RemeshContext<3>& context) override;
  // false: every edge evaluated in every regularisation sweep (the reference for tests; the
  // default reuses a refusal while nothing around the edge changed, with the same result).
  void set_reuse_refusals(bool reuse) { reuse_refusals_ = reuse; }

 private:
  DelaunayOptions options_;
  bool reuse_refusals_ = true;
};

std::unique_ptr<Remesher<3>> make_delaunay_remesher(JsonReader& reader);

}  // namespace dsnake
