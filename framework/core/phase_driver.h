// PhaseDriver<D>: runs an experiment's phases (§3, §6) on a snake. It owns what every way of
// minimising shares: the energies and their phase weights, binding them to the snake (again
// after every remesh that changes its topology), the remesh schedule and the observers. How a
// phase moves the snake is a Minimizer: the snake iteration of §3.1 (SnakeStep, evolver.h) or
// one global Ceres solve per round (GlobalSolve, global_solver.h).
#pragma once

#include "framework/core/energy.h"
#include "framework/core/move_guard.h"
#include "framework/core/options.h"
#include "framework/core/remesher.h"

#include <limits>
#include <memory>
#include <optional>
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

// A phase's schedule and stopping rules: the keys of an experiment file's "phases[k]" (its
// "remesh" stages are read by the remesher registry).
struct PhaseOptions {
  std::string name;         // shown in progress lines and result.json; "" for "#k"
  int iterations = 100;     // iteration budget
  double tolerance = 0.0;   // stop when the largest displacement (physical units) is below; 0: never
  int every = 1;            // run the remesher pipeline every `every` iterations
  // The windowed stop (framework/core/stall.h; the snake iteration only): every `window`
  // iterations, stop when the template vertices' net move per iteration, the centroid's motion
  // removed, is below `tolerance` and the total energy changed by less than energy_tolerance of
  // itself. 0: off.
  int window = 0;
  double energy_tolerance = 1e-3;
  // With a window: when every term weighted in this phase is higher than at the window's start,
  // the snake got worse by every measure the phase has (a drift, not a balance of its forces,
  // which trades one term for another): go back to the window's start and stop.
  bool stop_when_worse = false;
  // Per-energy weights for this phase, in the energies' order (empty: their own weights); 0
  // switches a term off, e.g. §3's first phase with the deformation and external forces only.
  std::vector<double> weights;

  template <class V>
  void visit(V& v) {
    v(name, Key{"name", "", "shown in progress lines and result.json (default \"#k\")"});
    v(iterations, Key{"iterations", "iterations", "the phase's iteration budget (global solve: Ceres iterations are counted)", Range::closed(0, 10000000)});
    v(tolerance, Key{"tolerance", "mm", "stop when the largest vertex move of an iteration is below (0: never)", Range::at_least(0)});
    v(every, Key{"every", "iterations", "run the remeshing stages every `every` iterations", Range::at_least(1)});
    v(window, Key{"window", "iterations",
                  "the windowed stop (needs tolerance > 0; snake iteration only): every `window` iterations, stop when no "
                  "template vertex moved more than `tolerance` per iteration on the net once the centroid's motion is "
                  "removed, and the total energy changed by less than energy_tolerance of itself: a snake that only "
                  "slides or oscillates has converged (0: off)",
                  Range::closed(0, 10000000)});
    v(energy_tolerance, Key{"energy_tolerance", "1", "the windowed stop's largest relative change of the total energy over a window",
                            Range::at_least(0)});
    v(stop_when_worse, Key{"stop_when_worse", "",
                           "with `window`: every `window` iterations, when every term with a weight in this phase is higher "
                           "than at the window's start (worse by every measure: a drift, not a balance that trades one term "
                           "for another), go back to the window's start and stop"});
    v(weights, Key{"weights", "1", "one weight per energy for this phase, in the energies' order (0 switches a term off); default: their own weights"});
  }
  void check() const {
    if (window > 0 && tolerance <= 0)
      throw OptionError{"window", "needs a tolerance > 0 (the net move per iteration below which the shape is still)"};
    if (stop_when_worse && window <= 0)
      throw OptionError{"stop_when_worse", "needs a window > 0 (the iterations between the compared states)"};
  }
};

template <int D>
struct Phase : PhaseOptions {
  // The remeshing run every `every` iterations (null: none); an experiment's stages come as one
  // RemeshPipeline (remesh/pipeline.h), which reports per stage.
  std::unique_ptr<Remesher<D>> remesher;
};

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

// The numeric watchdog, the experiment file's "watchdog": the snake iteration stops as
// diverged when a vertex moves by a non-finite amount or by more than max_move in one
// iteration, when remeshing would leave more than max_vertices vertices (the remeshers stop at
// that budget, remesher.h), or when the snake collapses: its enclosed area (2D) or volume (3D),
// signed, falls below min_size times that of the run's start (a shape shrunk to a point or
// turned inside out). The positions are then those of the last iteration that passed, and the
// run's status is "diverged" (exit code 3). The global solve applies the same checks at each of
// its iterations. max_vertices is also the budget that a phase's remeshing lengths are checked
// against when an experiment is assembled. In the file, max_move 0 is the image's diagonal (the
// runner sets it); to the driver it means no bound.
struct WatchdogOptions {
  double max_move = 0;         // mm per iteration; 0: the image's diagonal (the driver: no bound)
  int max_vertices = 1000000;  // after remeshing
  double min_size = 1e-3;      // share of the start's enclosed area / volume; 0: off

  // Non-finite moves only: what a driver checks unless told otherwise.
  static WatchdogOptions off() { return {0, std::numeric_limits<int>::max(), 0}; }

  template <class V>
  void visit(V& v) {
    v(max_move, Key{"max_move", "mm per iteration",
                    "a vertex moving more than this in one iteration stops the run as diverged (0: the image's "
                    "diagonal, farther than any meaningful move)",
                    Range::at_least(0)});
    v(max_vertices, Key{"max_vertices", "vertices",
                        "remeshing that would leave more vertices than this stops the run as diverged (a runaway "
                        "refinement); a phase whose remeshing edge length needs more for the placed template is refused",
                        Range::closed(3, 1e8)});
    v(min_size, Key{"min_size", "1 (share)",
                    "a snake whose enclosed area (2D) or volume (3D), signed, falls below this share of the placed "
                    "template's (shrunk to a point or turned inside out) stops the run as diverged at that iteration (0: off)",
                    Range::closed_open(0, 1)});
  }
};
using Watchdog = WatchdogOptions;

// Why a phase diverged: what was seen, at which iteration (within the phase), which vertex and
// which energy term (its type and index; "remesh" for the vertex cap).
struct Divergence {
  std::string reason;
  int phase_iteration = 0;
  int vertex = -1;
  std::string term;
  int term_index = -1;
  double move = 0;  // the offending move (inf or NaN when not finite)
  // A collapse: the enclosed area or volume over the start's, at the iteration that failed.
  std::optional<double> size_share;
};

struct PhaseSummary {
  int iterations = 0;
  EvolveStatus status = EvolveStatus::kIterationBudget;
  // The largest vertex move (mm) of the iteration whose result the phase ends on: after a stop
  // when worse, that of the iteration that made the restored window start (0 for the phase's own
  // start).
  double last_displacement = 0;
  // kConverged: "displacement" (one iteration's largest move below the tolerance), "window"
  // (the windowed stop: the shape still and the energy flat while the centroid may move) or
  // "worse" (stop_when_worse: back to the window's start).
  std::string converged_on;
  double centroid_rate = 0;  // the windowed stop: the centroid's move per iteration in its last window (mm)
  std::vector<RemeshReport> remesh_reports;  // the last pass of each stage
  MoveGuardReport move_guard;                // the move guard's interventions in this phase
  std::optional<Divergence> divergence;      // kDiverged by the snake iteration's watchdog
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
class PhaseDriver;

// How a phase moves the snake. run_phase() iterates until the phase's budget, convergence or
// divergence, asks the driver to remesh on its schedule and reports every iteration through it.
template <int D>
class Minimizer {
 public:
  virtual ~Minimizer() = default;
  virtual std::string type() const = 0;
  virtual PhaseSummary run_phase(PhaseDriver<D>& driver, Snake<D>& snake, const Phase<D>& phase, int phase_index) = 0;
};

template <int D>
class PhaseDriver {
 public:
  // The energies' weights must be positive; every vertex must be governed by some energy.
  PhaseDriver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies, std::unique_ptr<Minimizer<D>> minimizer);
  virtual ~PhaseDriver() = default;

  void add_observer(EvolverObserver<D>* observer) { observers_.push_back(observer); }
  // Whether to evaluate every energy's value after each snake iteration (the energy trace).
  void set_trace_energy(bool on) { trace_energy_ = on; }
  bool trace_energy() const { return trace_energy_; }
  // The check on the snake iteration's moves (null: none, the default). Minimizers other than
  // SnakeStep (the global solve) do not use it.
  void set_move_guard(std::unique_ptr<MoveGuard<D>> guard) { move_guard_ = std::move(guard); }
  MoveGuard<D>* move_guard() const { return move_guard_.get(); }
  // The numeric watchdog of the snake iteration (default: WatchdogOptions::off(), non-finite moves only).
  void set_watchdog(const Watchdog& watchdog) { watchdog_ = watchdog; }
  const Watchdog& watchdog() const { return watchdog_; }

  // Runs the phases on the snake in place.
  EvolveSummary run(Snake<D>& snake, std::vector<Phase<D>>& phases);

  // For minimizers. Binds the energies if the snake is not the bound one or its topology changed.
  void bind(const Snake<D>& snake);
  std::vector<WeightedEnergy<D>>& energies() { return energies_; }
  const std::vector<WeightedEnergy<D>>& energies() const { return energies_; }
  // w_e E_e(q) per term, in the order given (binds first if needed).
  std::vector<double> energy_terms(const Snake<D>& snake);
  // Runs the phase's remesher at `phase_iteration` of its schedule, tells the observers, rebinds
  // the energies; one report per stage.
  std::vector<RemeshReport> remesh(Snake<D>& snake, const Phase<D>& phase, int phase_iteration);
  // Numbers the iteration (counted over all phases), sets its vertex count and tells the observers.
  void report(IterationInfo& info, const Snake<D>& snake);
  // The snake's enclosed area (2D) or volume (3D) over that of the run's start, signed (NaN
  // before run()); the watchdog's collapse check compares it with min_size.
  double size_share(const Snake<D>& snake) const;
  // The watchdog's checks that every minimizer shares: an iteration's largest move (null when
  // finite and at most max_move; `vertex` is the vertex that made it), a collapse (null while
  // the share is at least min_size), and a remeshing past the vertex budget (null if none of
  // its reports says so and the snake has at most max_vertices vertices).
  std::optional<Divergence> check_move(double move, int vertex, int phase_iteration) const;
  std::optional<Divergence> check_collapse(const Snake<D>& snake, int phase_iteration) const;
  std::optional<Divergence> check_vertex_budget(const Snake<D>& snake, const std::vector<RemeshReport>& reports,
                                                int phase_iteration) const;
  Minimizer<D>& minimizer() { return *minimizer_; }

 private:
  EnergyContext<D> context_;
  std::vector<WeightedEnergy<D>> energies_;
  std::unique_ptr<Minimizer<D>> minimizer_;
  std::vector<EvolverObserver<D>*> observers_;
  std::unique_ptr<MoveGuard<D>> move_guard_;
  Watchdog watchdog_ = Watchdog::off();
  std::vector<double> base_weights_;  // the energies' own weights (phases may override them)
  bool trace_energy_ = true;
  int iterations_ = 0;
  double start_measure_ = std::numeric_limits<double>::quiet_NaN();  // signed area / volume at run()
  uint64_t bound_version_ = ~uint64_t(0);
  int bound_vertices_ = -1;
  const Snake<D>* bound_snake_ = nullptr;
};

}  // namespace dsnake
