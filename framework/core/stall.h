// The snake's windowed stop, for a stable end point. The displacement stop of a phase
// (`tolerance`: the largest move of one iteration) never fires for a snake that keeps sliding at
// a steady rate (ASAP leaves translation free, and under weak forces the snake drifts) or that
// oscillates about an edge (a unit-normalised force). StallDetector compares the template
// vertices every `window` iterations with where they were `window` iterations before: once the
// centroid's motion is removed, if none of them moved more than `tolerance` per iteration on
// the net, and the total energy changed by less than `energy_tolerance` of itself, the snake has
// converged: its shape has stopped changing and the energy is flat, whatever its centroid does.
// Template vertices keep their identity through remeshing, so the window spans remeshing passes.
#pragma once

#include "framework/core/shape.h"

#include <vector>

namespace dsnake {

template <int D>
class StallDetector {
 public:
  // window 0: never stalls.
  StallDetector(int window, double tolerance, double energy_tolerance)
      : window_(window), tolerance_(tolerance), energy_tolerance_(energy_tolerance) {}

  // Opens the first window at the phase's start (iteration 0).
  void start(const Snake<D>& snake, double total_energy);

  // After iteration `iteration` (from 1) with the snake and the total energy then (the sum of
  // the finite weighted terms). Every `window` iterations closes the window (true when it
  // shows a stall) and opens the next.
  bool stalled(int iteration, const Snake<D>& snake, double total_energy);

  // Of the last window that ended: the largest net move of a template vertex per iteration with
  // the centroid's motion removed, and the centroid's move per iteration (mm).
  double shape_rate() const { return shape_rate_; }
  double centroid_rate() const { return centroid_rate_; }

 private:
  void checkpoint(int iteration, const Snake<D>& snake, double total_energy);

  int window_;
  double tolerance_, energy_tolerance_;
  int start_ = 0;            // the iteration of the checkpoint
  std::vector<int> ids_;     // template ids of the checkpoint's vertices
  PointList<D> positions_;   // their positions then, centroid removed
  Point<D> centroid_ = Point<D>::Zero();
  double energy_ = 0;
  double shape_rate_ = 0, centroid_rate_ = 0;
};

}  // namespace dsnake
