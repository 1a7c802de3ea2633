// §5.3 refinement: every triangle with an edge longer than the threshold gets a vertex at its
// barycentre and is split 1 -> 3 (a triangle too thin for that has its longest edge split at
// the midpoint instead, see refine.cpp). The threshold follows the schedule of §6: it falls
// geometrically from `start_max_edge` to `max_edge` over the first `ramp` share of the phase,
// so that the snake reaches its full resolution gradually. New vertices are free (id -1). A pass
// stops splitting at the context's vertex budget (and reports over_budget).
#pragma once

#include "framework/core/options.h"
#include "framework/core/remesher.h"
#include "remesh/pass.h"

namespace dsnake {

struct RefineOptions {
  double max_edge = 2.0;        // final threshold, physical units
  double start_max_edge = 0;    // threshold at the phase's first iteration; 0: max_edge (no schedule)
  double ramp = 0.5;            // share of the phase's iterations over which the threshold falls

  template <class V>
  void visit(V& v) {
    v(max_edge, Key{"max_edge", "mm", "final threshold: a triangle with a longer edge is split", Range::greater_than(0)});
    v(start_max_edge, Key{"start_max_edge", "mm",
                          "threshold at the phase's first iteration, falling geometrically to max_edge (§6); 0: no schedule",
                          Range::at_least(0)});
    v(ramp, Key{"ramp", "1", "share of the phase's iterations over which the threshold falls", Range::open_closed(0, 1)});
  }
  void check() const {
    if (start_max_edge != 0 && !(start_max_edge >= max_edge))
      throw OptionError{"start_max_edge", "must be 0 (no schedule) or >= max_edge"};
  }
};

// The threshold at iteration t of a phase of T iterations (§6): start * (end/start)^(t / (ramp T)).
double refine_threshold(const RefineOptions& options, int phase_iteration, int phase_iterations);

class RefineRemesher final : public EditStage {
 public:
  using Options = RefineOptions;
  static constexpr const char* kType = "refine";
  static constexpr const char* kSummary =
      "§5.3 refinement: 1 -> 3 splits of every triangle with an edge over the (scheduled) threshold";

  explicit RefineRemesher(const RefineOptions& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  bool edits_can_cross() const override { return false; }  // the new triangles tile the old ones
  RemeshReport run(EditMesh& m, const RemeshContext<3>& context) override;
  // The final threshold (a schedule's start is at least as long).
  std::optional<RefinementLength> refinement_length() const override {
    return RefinementLength{"max_edge", options_.max_edge};
  }

 private:
  RefineOptions options_;
};

}  // namespace dsnake
