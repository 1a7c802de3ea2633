// §5.4 simplification: half-edge collapses of free vertices onto a neighbour, for
//  - every edge shorter than min_edge (one voxel edge by default: the image's smallest
//    spacing, 1 without an image), and
//  - triangles that are small relative to their curvature [Hoppe et al. 1993]: a free vertex
//    whose removal moves the surface by less than curvature_ratio * l / 8 (l: the collapsed
//    edge's length; for a sphere of radius R the sagitta of a chord l is l^2 / 8R, so this
//    collapses edges shorter than curvature_ratio * R), as long as no new edge exceeds max_edge.
// A deformation vertex is never removed (an edge between two of them stays, even if short).
// A collapse that breaks the link condition (would make the mesh non-manifold), turns a
// triangle beyond max_normal_change_deg, pushes the smallest angle around a and b below
// min(its old value, 15 degrees), or makes the fan cross the surface is rejected (so a short
// edge can survive when collapsing it would do more harm). With `regularize` (our addition), the
// stage then removes valence defects that flips cannot: collapses that bring valences closer to
// 6, each sweep followed by the delaunay stage's flips (simplify.cpp). With `relax` (ours too)
// it ends with one sweep of the uniform stage's relaxation (§5.1), with that stage's checks: the
// flips and collapses leave vertices off the centres of their new one-rings, and a pass that
// ends relaxed lets the next one's flips find more regular connectivity. A relaxed mesh also has
// fewer long edges for the refinement: 1566 vertices instead of 1942 on the ellipsoid of
// tests/remesh/clean_mesh_test.cpp, and on the half-size lung of
// tests/experiments/end_to_end/figures_reproduction_test.cpp 2524 vertices instead of 3199.
#pragma once

#include "framework/core/options.h"
#include "framework/core/remesher.h"
#include "remesh/pass.h"

#include <vector>

namespace dsnake {

struct SimplifyOptions {
  double min_edge = 0;                // physical units; 0: one voxel edge (image spacing, min)
  double max_edge = 0;                // longest edge a curvature collapse may create; 0: 2 * min_edge
  double curvature_ratio = 0.1;       // 0 disables the curvature collapses
  double max_normal_change_deg = 45;  // largest turn of a fan triangle's normal per collapse
  bool regularize = true;             // valence collapses and flips after the length collapses
  bool relax = true;                  // then one sweep of the uniform stage's relaxation

  template <class V>
  void visit(V& v) {
    v(min_edge, Key{"min_edge", "mm", "edges shorter than this are collapsed; 0: one voxel edge (the image's smallest spacing)",
                    Range::at_least(0)});
    v(max_edge, Key{"max_edge", "mm", "longest edge a curvature collapse may create; 0: 2 * min_edge", Range::at_least(0)});
    v(curvature_ratio, Key{"curvature_ratio", "1",
                           "collapse where the surface moves by less than curvature_ratio * l / 8 [Hoppe 1993]; 0: off",
                           Range::closed(0, 1)});
    v(max_normal_change_deg, Key{"max_normal_change_deg", "degrees",
                                 "largest turn of a fan triangle's normal per collapse", Range::open_closed(0, 180)});
    v(regularize, Key{"regularize", "",
                      "then collapses of free vertices that bring valences closer to 6 (no new edge over 2.3 mean edges), "
                      "each sweep followed by the delaunay stage's Delaunay and valence flips"});
    v(relax, Key{"relax", "",
                 "finally one sweep of the uniform stage's relaxation (§5.1): more regular, but fewer vertices after refinement"});
  }
  void check() const {
    if (max_edge != 0 && min_edge != 0 && !(min_edge < max_edge)) throw OptionError{"min_edge", "must be < max_edge"};
  }
};

class SimplifyRemesher final : public EditStage {
 public:
  using Options = SimplifyOptions;
  static constexpr const char* kType = "simplify";
  static constexpr const char* kSummary =
      "§5.4 simplification: half-edge collapses of free vertices on short or flat edges [Hoppe et al. 1993]";

  explicit SimplifyRemesher(const SimplifyOptions& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  RemeshReport run(EditMesh& m, const RemeshContext<3>& context) override;
  // false: every candidate evaluated in every sweep (the reference for tests; the default
  // reuses a refusal while nothing around the candidate changed, with the same result).
  void set_reuse_refusals(bool reuse) { reuse_refusals_ = reuse; }

 private:
  int regularize(EditMesh& m, double mean_edge, double cos_max, std::vector<int>& fan,
                 std::vector<Triangle>& fresh) const;

  SimplifyOptions options_;
  bool reuse_refusals_ = true;
};

namespace remesh_detail {

// A collapse candidate: free vertex a and its nearest neighbour b, at distance len >= 0.
struct CollapseCandidate {
  double len;
  int a, b;
};
// Sorts candidates listed in increasing a by (len, a): the order in which simplify tries them.
// `scratch`: a buffer, resized as needed.
void sort_by_length(std::vector<CollapseCandidate>& candidates, std::vector<CollapseCandidate>& scratch);

}  // namespace remesh_detail

}  // namespace dsnake
