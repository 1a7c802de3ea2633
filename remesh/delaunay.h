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
// smaller of the two triangles' minimum angles below min_angle_deg, and moves the valence
// defects that such flips leave (5-7 pairs) by flips that keep the valences' deviation, when
// one or two further flips then let them cancel with a nearby defect (our addition).
#pragma once

#include "framework/core/options.h"
#include "framework/core/remesher.h"
#include "remesh/pass.h"

#include <string>

namespace dsnake {

enum class DelaunayMethod { kFlips, kPlanar };
template <>
struct EnumNames<DelaunayMethod> {
  static constexpr std::array<std::pair<DelaunayMethod, const char*>, 2> table{
      {{DelaunayMethod::kFlips, "flips"}, {DelaunayMethod::kPlanar, "planar"}}};
};

struct DelaunayOptions {
  DelaunayMethod method = DelaunayMethod::kFlips;
  double max_dihedral_deg = 30;  // largest bend across an edge that a flip may straighten
  bool regularize = true;        // valence-driven flips after the Delaunay pass
  double min_angle_deg = 25;     // floor on triangle angles for the valence flips

  template <class V>
  void visit(V& v) {
    v(method, Key{"method", "", "intrinsic Delaunay by edge flips, or planar Delaunay of parameterised disc patches (§5.2)"});
    v(max_dihedral_deg, Key{"max_dihedral_deg", "degrees", "largest bend across an edge that a flip may straighten",
                            Range::open(0, 180)});
    v(regularize, Key{"regularize", "", "valence-driven flips (towards valence 6) after the Delaunay pass"});
    v(min_angle_deg, Key{"min_angle_deg", "degrees", "floor on triangle angles for the valence flips",
                         Range::closed_open(0, 60)});
  }
};

class DelaunayRemesher final : public EditStage {
 public:
  using Options = DelaunayOptions;
  static constexpr const char* kType = "delaunay";
  static constexpr const char* kSummary =
      "§5.2 mesh connectivity: Delaunay by edge flips or planar patches, then valence-regularising flips";

  explicit DelaunayRemesher(const DelaunayOptions& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  RemeshReport run(EditMesh& m, const RemeshContext<3>& context) override;
  // false: every edge evaluated in every regularisation sweep (the reference for tests; the
  // default reuses a refusal while nothing around the edge changed, with the same result).
  void set_reuse_refusals(bool reuse) { reuse_refusals_ = reuse; }

 private:
  DelaunayOptions options_;
  bool reuse_refusals_ = true;
};

}  // namespace dsnake
