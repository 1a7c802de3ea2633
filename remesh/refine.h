// §5.3 refinement: every triangle with an edge longer than the threshold gets a vertex at its
// barycentre and is split 1 -> 3 (a triangle too thin for that has its longest edge split at
// the midpoint instead, see refine.cpp). The threshold follows the schedule of §6: it falls
// geometrically from `start_max_edge` to `max_edge` over the first `ramp` share of the phase,
// so that the snake reaches its full resolution gradually. New vertices are free (id -1).
#pragma once

#include "framework/json_reader.h"
#include "framework/remesher.h"
#include "remesh/pass.h"

#include <memory>

namespace dsnake {

struct RefineOptions {
  double max_edge = 2.0;        // final threshold, physical units
  double start_max_edge = 0;    // threshold at the phase's first iteration; 0: max_edge (no schedule)
  double ramp = 0.5;            // share of the phase's iterations over which the threshold falls
};

// The threshold at iteration t of a phase of T iterations (§6): start * (end/start)^(t / (ramp T)).
double refine_threshold(const RefineOptions& options, int phase_iteration, int phase_iterations);

class RefineRemesher : public EditStage {
 public:
  explicit RefineRemesher(RefineOptions options) : options_(options) {}
  std::string type() const override { return "refine"; }
  bool edits_can_cross() const override { return false; }  // the new triangles tile the old ones
  RemeshReport run(remesh_detail::EditMesh& m, const RemeshContext<3>& context) override;

 private:
  RefineOptions options_;
};

std::unique_ptr<Remesher<3>> make_refine_remesher(JsonReader& reader);

}  // namespace dsnake
