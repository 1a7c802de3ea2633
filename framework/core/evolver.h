// SnakeStep<D>: the snake iteration of §3.1 as a Minimizer. Each iteration moves every vertex to
// the weighted average of the positions that each force alone would give,
//   q_v(t+1) = sum_{e governs v} w_e propose_e(q(t))_v / sum_{e governs v} w_e,
// e.g. (q_int + kappa q_ext + eta q_def) / (1 + kappa + eta) for a deformation vertex and
// (q_int + kappa q_ext) / (1 + kappa) for a free one (§6); a term that governs marked vertices
// only (a landmark spring) enters the averages of those vertices alone. A phase runs until its iteration
// budget or until the largest vertex displacement is below its tolerance, remeshing every
// `every` iterations. The driver's move guard, if any, may shorten or cancel moves before they
// are made (framework/core/move_guard.h). Evolver<D> is the PhaseDriver that uses it.
#pragma once

#include "framework/core/phase_driver.h"

namespace dsnake {

template <int D>
class SnakeStep final : public Minimizer<D> {
 public:
  static constexpr const char* kType = "snake";
  std::string type() const override { return kType; }
  PhaseSummary run_phase(PhaseDriver<D>& driver, Snake<D>& snake, const Phase<D>& phase, int phase_index) override;
  // One iteration of the averaged update, checked by the driver's move guard if it has one
  // (before the positions change); returns the largest displacement.
  double step(PhaseDriver<D>& driver, Snake<D>& snake);
  // The move guard's interventions since the current (or last) phase began.
  const MoveGuardReport& guard_report() const { return guard_report_; }
  // The vertex with the largest (or a non-finite) move of the last step, and the energy term
  // whose proposal for it moves farthest (or is not finite): the watchdog's report.
  int last_worst_vertex() const { return worst_vertex_; }
  int blame_term(const Snake<D>& snake_before, int vertex) const;
  // The energy term whose proposals alone, made from `snake_before`, shrink its enclosed area or
  // volume the most: the collapse's report.
  int blame_collapse(PhaseDriver<D>& driver, const Snake<D>& snake_before) const;

 private:
  std::vector<PointList<D>> proposals_;  // per energy, reused between iterations
  std::vector<Governs> governs_;           // per energy, for the averaging loop
  std::vector<std::span<const uint8_t>> masks_;  // per energy: governed_mask() (marked vertices)
  PointList<D> next_;  // after step(): the positions before it
  std::vector<double> moves_;  // per vertex, the last step's move (inf if not finite)
  MoveGuardReport guard_report_;
  int worst_vertex_ = -1;
};

// The phase driver with the snake iteration.
template <int D>
class Evolver : public PhaseDriver<D> {
 public:
  Evolver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies)
      : PhaseDriver<D>(context, std::move(energies), std::make_unique<SnakeStep<D>>()) {}
  // One iteration of the averaged update; returns the largest displacement.
  double step(Snake<D>& snake) { return static_cast<SnakeStep<D>&>(this->minimizer()).step(*this, snake); }
};

}  // namespace dsnake
