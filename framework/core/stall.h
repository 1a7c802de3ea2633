// The snake's windowed stops, for a stable end point. The displacement stop of a phase
// (`tolerance`: the largest move of one iteration) never fires for a snake that keeps sliding at
// a steady rate (ASAP leaves translation free, and under weak forces the snake drifts) or that
// oscillates about an edge (a unit-normalised force). StallDetector compares the template
// vertices every `window` iterations with where they were `window` iterations before: once the
// centroid's motion is removed, if none of them moved more than `tolerance` per iteration on
// the net, and the total energy changed by less than `energy_tolerance` of itself, the snake has
// converged: its shape has stopped changing and the energy is flat, whatever its centroid does.
// Template vertices keep their identity through remeshing, so the window spans remeshing passes.
//
// With `stop_when_worse`, the same window also ends a drift: the snake iteration (§3.1) moves
// every vertex to the weighted mean of the terms' proposals, a balance of forces rather than a
// descent on their sum, and nothing else stops it when every term gets worse. When every term
// with a weight in the phase is higher than at the window's start, that start was better by every
// measure the phase has: the detector keeps the whole snake of each window's start for the phase
// to go back to. A trade-off (one term falls while another rises) never ends it.
#pragma once

#include "framework/core/shape.h"

#include <vector>

namespace dsnake {

// The sum of the finite terms (an external field without a potential has none).
double finite_total(const std::vector<double>& terms);

// How a window ended.
enum class WindowEnd {
  kOpen,    // not at a window's end yet
  kMoving,  // the window ended and the snake is still changing: the next window opens
  kStill,   // the shape stopped changing and the energy is flat: converged
  kWorse    // every weighted term rose (stop_when_worse): go back to checkpoint()
};

template <int D>
class StallDetector {
 public:
  // window 0: never stalls.
  StallDetector(int window, double tolerance, double energy_tolerance, bool stop_when_worse = false)
      : window_(window), tolerance_(tolerance), energy_tolerance_(energy_tolerance), stop_when_worse_(stop_when_worse) {}

  // Opens the first window at the phase's start (iteration 0) with the weighted terms then.
  void start(const Snake<D>& snake, const std::vector<double>& terms);

  // After iteration `iteration` (from 1) with the snake and its weighted terms then, the
  // phase's weights (a term counts for stop_when_worse where its weight is > 0) and that
  // iteration's largest vertex move (mm). Every `window` iterations closes the window and,
  // unless it ends kWorse, opens the next.
  WindowEnd close(int iteration, const Snake<D>& snake, const std::vector<double>& terms,
                  const std::vector<double>& weights, double move);

  // Of the last window that ended: the largest net move of a template vertex per iteration with
  // the centroid's motion removed, and the centroid's move per iteration (mm).
  double shape_rate() const { return shape_rate_; }
  double centroid_rate() const { return centroid_rate_; }
  // The snake (kept with stop_when_worse only), its terms and the largest move of the iteration
  // that made it (0 at the phase's start), at the open window's start.
  const Snake<D>& checkpoint() const { return snake_; }
  const std::vector<double>& checkpoint_terms() const { return terms_; }
  double checkpoint_move() const { return move_; }

 private:
  void checkpoint(int iteration, const Snake<D>& snake, const std::vector<double>& terms, double move);

  int window_;
  double tolerance_, energy_tolerance_;
  bool stop_when_worse_;
  int start_ = 0;            // the iteration of the checkpoint
  std::vector<int> ids_;     // template ids of the checkpoint's vertices
  PointList<D> positions_;   // their positions then, centroid removed
  Point<D> centroid_ = Point<D>::Zero();
  std::vector<double> terms_;  // the weighted terms then
  Snake<D> snake_;             // the whole snake then (stop_when_worse)
  double move_ = 0;            // the largest move of the iteration that made it (mm)
  double shape_rate_ = 0, centroid_rate_ = 0;
};

}  // namespace dsnake
