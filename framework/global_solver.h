// GlobalSolver<D>: the global-solve baseline. It minimises the same total energy as the snake,
// E(q) = sum_e w_e E_e(q), in one non-linear least-squares problem over all vertex positions
// (plus ASAP's per-vertex similarities and ARAP's rotations), with Ceres Solver. The snake
// scheme of §3.1 is a coordinate descent on the same terms; this is what it is compared with.
// Phases run in order; a phase with remeshers solves, then remeshes and re-solves from the
// remeshed state `remesh_rounds` times, the remeshers' schedule (§6) advancing with the rounds.
// Observers see every Ceres iteration as an iteration (the energy trace, progress, figures).
#pragma once

#include "framework/evolver.h"
#include "framework/global_problem.h"

#include <vector>

namespace dsnake {

template <int D>
class GlobalSolver {
 public:
  // Every energy must have a least-squares form (has_least_squares_form(); the experiment reader
  // checks it); the external term needs context.potential.
  GlobalSolver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies, GlobalSolverOptions options);

  void add_observer(EvolverObserver<D>* observer) { observers_.push_back(observer); }

  // Runs the phases on the snake in place. Ceres' summary of every solve is in solves().
  EvolveSummary run(Snake<D>& snake, std::vector<Phase<D>>& phases);
  // One Ceres solve of the total energy from the snake's positions, written back to it.
  GlobalSolveSummary solve(Snake<D>& snake, const std::function<bool(int)>& on_iteration = {});

  // w_e E_e(q) per term, in the order given (binds the energies to the snake first if needed).
  std::vector<double> energy_terms(const Snake<D>& snake);
  const std::vector<WeightedEnergy<D>>& energies() const { return energies_; }
  // Per phase, Ceres' summary of each of its solves.
  const std::vector<std::vector<GlobalSolveSummary>>& solves() const { return solves_; }

 private:
  void bind(const Snake<D>& snake);

  EnergyContext<D> context_;
  std::vector<WeightedEnergy<D>> energies_;
  GlobalSolverOptions options_;
  std::vector<EvolverObserver<D>*> observers_;
  std::vector<double> base_weights_;  // the energies' own weights (phases may override them)
  std::vector<std::vector<GlobalSolveSummary>> solves_;
  uint64_t bound_version_ = ~uint64_t(0);
  int bound_vertices_ = -1;
};

}  // namespace dsnake
