// The windowed stop; see stall.h.
#include "framework/core/stall.h"

#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {

// The centroid of the vertices carrying template ids.
template <int D>
Point<D> template_centroid(const Snake<D>& snake) {
  Point<D> c = Point<D>::Zero();
  int n = 0;
  for (int v = 0; v < snake.num_vertices(); ++v)
    if (snake.is_deformation_vertex(v)) c += snake.positions()[v], ++n;
  return n > 0 ? Point<D>(c / n) : c;
}

}  // namespace

template <int D>
void StallDetector<D>::start(const Snake<D>& snake, double total_energy) {
  checkpoint(0, snake, total_energy);
}

template <int D>
void StallDetector<D>::checkpoint(int iteration, const Snake<D>& snake, double total_energy) {
  start_ = iteration;
  centroid_ = template_centroid(snake);
  energy_ = total_energy;
  ids_.clear();
  positions_.clear();
  for (int v = 0; v < snake.num_vertices(); ++v)
    if (snake.is_deformation_vertex(v)) {
      ids_.push_back(snake.template_id(v));
      positions_.push_back(snake.positions()[v] - centroid_);
    }
}

// Serial, in vertex order: the same answer whatever the thread count.
template <int D>
bool StallDetector<D>::stalled(int iteration, const Snake<D>& snake, double total_energy) {
  if (window_ <= 0 || iteration - start_ < window_) return false;
  const Point<D> c = template_centroid(snake);
  double largest = 0;
  for (size_t k = 0; k < ids_.size(); ++k) {
    const int v = snake.vertex_of_template_id(ids_[k]);
    if (v < 0) continue;  // a template vertex removed by remeshing
    largest = std::max(largest, ((snake.positions()[v] - c) - positions_[k]).norm());
  }
  const int span = iteration - start_;
  shape_rate_ = largest / span;
  centroid_rate_ = (c - centroid_).norm() / span;
  const double scale = std::max(std::abs(total_energy), std::abs(energy_));
  const bool flat = std::abs(total_energy - energy_) <= energy_tolerance_ * scale;
  const bool still = std::isfinite(shape_rate_) && shape_rate_ < tolerance_;
  checkpoint(iteration, snake, total_energy);
  return still && flat;
}

template class StallDetector<2>;
template class StallDetector<3>;

}  // namespace dsnake
