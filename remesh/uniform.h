// §5.1 uniform distribution: each free vertex's one-ring is parameterised to a convex polygon
// on the unit circle by arc length (the vertex itself by its mean-value coordinates), the
// vertex is moved to the circle's centre, and that point is mapped back to the surface
// through the parameterised triangles. The vertex therefore stays on the current surface and
// cannot fold its fan over. Deformation vertices never move. Proposals are computed from the
// old positions (in parallel), then committed one by one in vertex order, each checked: a move
// that would turn a triangle's normal beyond max_normal_change_deg, push the fan's smallest
// angle below min(its old value, 15 degrees), or make the fan cross the surface is rejected.
#pragma once

#include "framework/core/options.h"
#include "framework/core/remesher.h"
#include "remesh/pass.h"

namespace dsnake {

struct UniformOptions {
  int iterations = 1;                 // relaxation sweeps per application
  double max_normal_change_deg = 45;  // largest turn of a fan triangle's normal per move

  template <class V>
  void visit(V& v) {
    v(iterations, Key{"iterations", "sweeps", "relaxation sweeps per application", Range::at_least(1)});
    v(max_normal_change_deg, Key{"max_normal_change_deg", "degrees", "largest turn of a fan triangle's normal per move",
                                 Range::open_closed(0, 180)});
  }
};

class UniformRemesher final : public EditStage {
 public:
  using Options = UniformOptions;
  static constexpr const char* kType = "uniform";
  static constexpr const char* kSummary =
      "§5.1 uniform distribution: each free vertex to the centre of its one-ring parameterised on the unit circle";

  explicit UniformRemesher(const UniformOptions& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  RemeshReport run(EditMesh& m, const RemeshContext<3>& context) override;

 private:
  UniformOptions options_;
};

}  // namespace dsnake
