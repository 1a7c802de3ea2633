// The windowed stops; see stall.h.
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

// True when every term with a weight, finite at both states, is higher in `now` than in
// `before`, and there is at least one such term.
bool every_term_rose(const std::vector<double>& weights, const std::vector<double>& before,
                     const std::vector<double>& now) {
  int compared = 0;
  for (size_t e = 0; e < weights.size() && e < before.size() && e < now.size(); ++e) {
    if (!(weights[e] > 0) || !std::isfinite(before[e]) || !std::isfinite(now[e])) continue;
    if (!(now[e] > before[e])) return false;
    ++compared;
  }
  return compared > 0;
}

}  // namespace

double finite_total(const std::vector<double>& terms) {
  double total = 0;
  for (double t : terms)
    if (std::isfinite(t)) total += t;
  return total;
}

template <int D>
void StallDetector<D>::start(const Snake<D>& snake, const std::vector<double>& terms) {
  checkpoint(0, snake, terms, 0.0);
}

template <int D>
void StallDetector<D>::checkpoint(int iteration, const Snake<D>& snake, const std::vector<double>& terms,
                                  double move) {
  start_ = iteration;
  move_ = move;
  centroid_ = template_centroid(snake);
  terms_ = terms;
  if (stop_when_worse_) snake_ = snake;
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
WindowEnd StallDetector<D>::close(int iteration, const Snake<D>& snake, const std::vector<double>& terms,
                                  const std::vector<double>& weights, double move) {
  if (window_ <= 0 || iteration - start_ < window_) return WindowEnd::kOpen;
  if (stop_when_worse_ && every_term_rose(weights, terms_, terms)) return WindowEnd::kWorse;
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
  const double energy = finite_total(terms), before = finite_total(terms_);
  const double scale = std::max(std::abs(energy), std::abs(before));
  const bool flat = std::abs(energy - before) <= energy_tolerance_ * scale;
  const bool still = std::isfinite(shape_rate_) && shape_rate_ < tolerance_;
  checkpoint(iteration, snake, terms, move);
  return still && flat ? WindowEnd::kStill : WindowEnd::kMoving;
}

template class StallDetector<2>;
template class StallDetector<3>;

}  // namespace dsnake
