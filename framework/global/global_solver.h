// GlobalSolve<D>: the global-solve baseline, a Minimizer of the phase driver. It minimises the
// same total energy as the snake, E(q) = sum_e w_e E_e(q), in one non-linear least-squares problem over all vertex positions
// (plus ASAP's per-vertex similarities and ARAP's rotations), with Ceres Solver. The snake
// scheme of §3.1 is a coordinate descent on the same terms; this is what it is compared with.
// Phases run in order; a phase with remeshers solves, then remeshes and re-solves from the
// remeshed state `remesh_rounds` times, the remeshers' schedule (§6) advancing with the rounds.
// Observers see every Ceres iteration as an iteration (the energy trace, progress, figures).
// The driver's watchdog applies at every iteration: a collapse or a remeshing past the vertex
// budget stops the run as diverged, as does the solve's own time bound (max_time_s).
#pragma once

#include "framework/global/global_problem.h"
#include "framework/core/phase_driver.h"

#include <chrono>
#include <functional>
#include <optional>

#include <vector>

namespace dsnake {

// The global solve as a Minimizer: per phase, one Ceres solve (and remesh_rounds more after
// remeshing when the phase has a remesher); every Ceres iteration is reported as an iteration.
template <int D>
class GlobalSolve final : public Minimizer<D> {
 public:
  static constexpr const char* kType = "global";
  // Every energy must have a least-squares form (has_least_squares_form(); the experiment
  // assembly checks it); the external term needs the driver context's potential.
  explicit GlobalSolve(GlobalSolverOptions options) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  PhaseSummary run_phase(PhaseDriver<D>& driver, Snake<D>& snake, const Phase<D>& phase, int phase_index) override;
  // One Ceres solve of the total energy from the snake's positions, written back to it (with
  // `options` instead of the solver's own, if given).
  GlobalSolveSummary solve(PhaseDriver<D>& driver, Snake<D>& snake, const std::function<bool(int)>& on_iteration = {},
                           const std::optional<GlobalSolverOptions>& options = std::nullopt);
  // Per phase run so far, Ceres' summary of each of its solves.
  const std::vector<std::vector<GlobalSolveSummary>>& solves() const { return solves_; }
  const GlobalSolverOptions& options() const { return options_; }

 private:
  double elapsed_s() const;  // since the first phase began
  Divergence time_bound(int phase_iteration) const;  // the report of a solve stopped at max_time_s

  GlobalSolverOptions options_;
  std::vector<std::vector<GlobalSolveSummary>> solves_;
  std::chrono::steady_clock::time_point start_;
};

// The phase driver with the global solve.
template <int D>
class GlobalSolver : public PhaseDriver<D> {
 public:
  GlobalSolver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies, GlobalSolverOptions options)
      : PhaseDriver<D>(context, std::move(energies), std::make_unique<GlobalSolve<D>>(std::move(options))) {}
  GlobalSolveSummary solve(Snake<D>& snake, const std::function<bool(int)>& on_iteration = {}) {
    return global().solve(*this, snake, on_iteration);
  }
  const std::vector<std::vector<GlobalSolveSummary>>& solves() { return global().solves(); }

 private:
  GlobalSolve<D>& global() { return static_cast<GlobalSolve<D>&>(this->minimizer()); }
};

}  // namespace dsnake
