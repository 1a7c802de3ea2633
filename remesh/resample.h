// 2D remeshing: resample the contour by arc length so that every edge between two free
// vertices lies in [min_edge, max_edge] (physical units). Deformation vertices are anchors:
// they keep their ids, positions and order; free vertices between two anchors are spread
// evenly along the current polyline. (A span between two adjacent anchors shorter than
// min_edge stays as it is: anchors are never merged.) The vertex count is found before anything
// is allocated: a resampling past the context's vertex budget leaves the snake as it was and
// reports over_budget.
#pragma once

#include "framework/core/options.h"
#include "framework/core/remesher.h"

namespace dsnake {

struct ResampleOptions {
  double min_edge = 0.5;  // physical units
  double max_edge = 2.0;  // physical units; >= 2 * min_edge so that a fit exists

  template <class V>
  void visit(V& v) {
    v(min_edge, Key{"min_edge", "mm", "shortest edge between two free vertices", Range::greater_than(0)});
    v(max_edge, Key{"max_edge", "mm", "longest edge; at least 2 * min_edge, so that a fit exists", Range::greater_than(0)});
  }
  void check() const {
    if (!(max_edge >= 2 * min_edge)) throw OptionError{"max_edge", "must be >= 2 * min_edge"};
  }
};

class ResampleRemesher final : public Remesher<2> {
 public:
  using Options = ResampleOptions;
  static constexpr const char* kType = "resample";
  static constexpr const char* kSummary =
      "2D resampling by arc length: free edges in [min_edge, max_edge], deformation vertices as anchors";

  explicit ResampleRemesher(const ResampleOptions& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  RemeshReport apply(Snake<2>& snake, const RemeshContext<2>& context) override;
  std::optional<RefinementLength> refinement_length() const override {
    return RefinementLength{"max_edge", options_.max_edge};
  }

 private:
  ResampleOptions options_;
};

}  // namespace dsnake
