// result.json's "pose"; see pose_report.h.
#include "experiments/output/pose_report.h"

#include "framework/core/alignment.h"

#include <vector>

namespace dsnake {

namespace {

template <int D>
std::vector<double> world_point(const Grid<D>& frame, const Point<D>& p) {
  const Point<D> w = frame.to_world(p);
  return std::vector<double>(w.data(), w.data() + D);
}

}  // namespace

template <int D>
nlohmann::ordered_json pose_json(const Snake<D>& start, const Snake<D>& end, const Grid<D>& frame) {
  const Moments<D> a = enclosed_moments(start.positions(), start.connectivity());
  const Moments<D> b = enclosed_moments(end.positions(), end.connectivity());
  // The frame is a rigid map of the world, so the shift's length is the same in both.
  return {{"centroid_start", world_point(frame, a.centroid)},
          {"centroid_end", world_point(frame, b.centroid)},
          {"centroid_shift", (b.centroid - a.centroid).norm()},
          {"measure_ratio", a.measure != 0 ? b.measure / a.measure : 0.0}};
}

template nlohmann::ordered_json pose_json<2>(const Snake<2>&, const Snake<2>&, const Grid<2>&);
template nlohmann::ordered_json pose_json<3>(const Snake<3>&, const Snake<3>&, const Grid<3>&);

}  // namespace dsnake
