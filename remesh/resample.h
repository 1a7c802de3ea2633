// 2D remeshing: resample the contour by arc length so that every edge between two free
// vertices lies in [min_edge, max_edge] (physical units). Deformation vertices are anchors:
// they keep their ids, positions and order; free vertices between two anchors are spread
// evenly along the current polyline. (A span between two adjacent anchors shorter than
// min_edge stays as it is: anchors are never merged.)
#pragma once

#include "framework/json_reader.h"
#include "framework/remesher.h"

#include <memory>

namespace dsnake {

struct ResampleOptions {
  double min_edge = 0.5;  // physical units
  double max_edge = 2.0;  // physical units; must be >= 2 * min_edge so that a fit exists
};

class ResampleRemesher : public Remesher<2> {
 public:
  explicit ResampleRemesher(ResampleOptions options) : options_(options) {}
  std::string type() const override { return "resample"; }
  RemeshReport apply(Snake<2>& snake, const RemeshContext<2>& context) override;

 private:
  ResampleOptions options_;
};

std::unique_ptr<Remesher<2>> make_resample_remesher(JsonReader& reader);

}  // namespace dsnake
