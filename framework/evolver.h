// Evolver<D>: the snake iteration of §3.1. Each iteration moves every vertex to the weighted
// average of the positions that each force alone would give,
//   q_v(t+1) = sum_{e governs v} w_e propose_e(q(t))_v / sum_{e governs v} w_e,
// e.g. (q_int + kappa q_ext + eta q_def) / (1 + kappa + eta) for a deformation vertex and
// (q_int + kappa q_ext) / (1 + kappa) for a free one (§6). Phases run in order, each with an
// iteration budget, a convergence tolerance on the largest vertex displacement and an optional
// remesher pipeline run every k iterations; observers see every iteration.
#pragma once

#include "framework/energy.h"
#include "framework/remesher.h"

#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace dsnake {

template <int D>
struct WeightedEnergy {
  double weight = 1.0;
  std::unique_ptr<Energy<D>> energy;
};

// Sets every energy's weight for `phase` (its "weights", or `base`), in place.
template <int D>
void apply_phase_weights(std::vector<WeightedEnergy<D>>& energies, const std::vector<double>& base,
                         const std::vector<double>& phase_weights);

// w_e E_e(q) per term, in the order given (0 for a term switched off, w_e = 0); the energies
// must be bound to the snake.
template <int D>
std::vector<double> weighted_energy_terms(const std::vector<WeightedEnergy<D>>& energies, const Snake<D>& snake);

template <int D>
struct Phase {
  int iterations = 100;     // iteration budget
  double tolerance = 0.0;   // stop when the largest displacement (physical units) is below; 0: never
  int every = 1;            // run the remesher pipeline every `every` iterations
  // Per-energy weights for this phase, in the energies' order (empty: their own weights); 0
  // switches a term off, e.g. §3's first phase with the deformation and external forces only.
  std::vector<double> weights;
  std::vector<std::unique_ptr<Remesher<D>>> remeshers;  // applied in order
  // How the pipeline runs: empty, each remesher's apply() in turn; set (3D experiments use
  // remesh's apply_pass), one pass over a shared editable mesh with the same result and one
  // report per remesher, without a connectivity rebuild between stages.
  std::function<std::vector<RemeshReport>(std::span<const std::unique_ptr<Remesher<D>>>, Snake<D>&,
                                          const RemeshContext<D>&)>
      remesh_pass;
};

// Runs the phase's remeshers on the snake (through remesh_pass when set); one report each.
template <int D>
std::vector<RemeshReport> run_remeshers(const Phase<D>& phase, Snake<D>& snake, const RemeshContext<D>& context);

struct IterationInfo {
  int phase = 0;
  int iteration = 0;           // counted over all phases, from 1
  int phase_iteration = 0;     // within the phase, from 1
  double max_displacement = 0; // largest vertex move of this iteration, physical units
  int vertices = 0;
  std::vector<double> energy_terms;  // w_e E_e(q) after the iteration (NaN where undefined)
  double total_energy = 0;           // sum of the finite terms
};

enum class EvolveStatus { kConverged, kIterationBudget, kDiverged };
std::string to_string(EvolveStatus status);

struct PhaseSummary {
  int iterations = 0;
  EvolveStatus status = EvolveStatus::kIterationBudget;
  double last_displacement = 0;
  std::vector<RemeshReport> remesh_reports;  // the last pass of each stage
};

struct EvolveSummary {
  int iterations = 0;
  EvolveStatus status = EvolveStatus::kIterationBudget;  // of the last phase, or kDiverged
  std::vector<PhaseSummary> phases;
};

template <int D>
class EvolverObserver {
 public:
  virtual ~EvolverObserver() = default;
  virtual void on_iteration(const IterationInfo& info, const Snake<D>& snake) {}
  virtual void on_remesh(const RemeshReport& report, const Snake<D>& snake) {}
  virtual void on_phase_end(int phase, const PhaseSummary& summary, const Snake<D>& snake) {}
};

template <int D>
class Evolver {
 public:
  // The energies' weights must be positive; every vertex must be governed by some energy.
  Evolver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies);

  void add_observer(EvolverObserver<D>* observer) { observers_.push_back(observer); }
  // Whether to evaluate every energy's value after each iteration (the energy trace).
  void set_trace_energy(bool on) { trace_energy_ = on; }

  // Runs the phases on the snake in place.
  EvolveSummary run(Snake<D>& snake, std::vector<Phase<D>>& phases);
  // One iteration of the averaged update; returns the largest displacement.
  double step(Snake<D>& snake);

  // w_e E_e(q) per term, in the order given (binds the energies to the snake first if needed).
  std::vector<double> energy_terms(const Snake<D>& snake);
  const std::vector<WeightedEnergy<D>>& energies() const { return energies_; }

 private:
  void bind_if_needed(const Snake<D>& snake);

  EnergyContext<D> context_;
  std::vector<WeightedEnergy<D>> energies_;
  std::vector<EvolverObserver<D>*> observers_;
  std::vector<double> base_weights_;  // the energies' own weights (phases may override them)
  bool trace_energy_ = true;
  uint64_t bound_version_ = ~uint64_t(0);
  const Snake<D>* bound_snake_ = nullptr;
  std::vector<PointList<D>> proposals_;  // per energy, reused between iterations
  PointList<D> next_;
};

}  // namespace dsnake
