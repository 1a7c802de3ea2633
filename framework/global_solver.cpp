#include "framework/global_solver.h"

#include "framework/errors.h"

#include <algorithm>
#include <cmath>

namespace dsnake {

template <int D>
GlobalSolver<D>::GlobalSolver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies,
                              GlobalSolverOptions options)
    : context_(context), energies_(std::move(energies)), options_(std::move(options)) {
  DSNAKE_ASSERT(!energies_.empty(), "at least one energy");
  for (const auto& e : energies_) {
    DSNAKE_ASSERT(e.weight > 0 && e.energy, "positive weight");
    base_weights_.push_back(e.weight);
  }
}

template <int D>
void GlobalSolver<D>::bind(const Snake<D>& snake) {
  if (bound_version_ == snake.topology_version() && bound_vertices_ == snake.num_vertices()) return;
  for (auto& e : energies_) e.energy->bind(context_, snake);
  bound_version_ = snake.topology_version();
  bound_vertices_ = snake.num_vertices();
}

template <int D>
std::vector<double> GlobalSolver<D>::energy_terms(const Snake<D>& snake) {
  bind(snake);
  return weighted_energy_terms(energies_, snake);
}

// Builds E = sum_e w_e E_e as residual blocks at the snake's positions and minimises it.
template <int D>
GlobalSolveSummary GlobalSolver<D>::solve(Snake<D>& snake, const std::function<bool(int)>& on_iteration) {
  bind(snake);
  GlobalProblem<D> problem(snake);
  for (const auto& e : energies_)
    DSNAKE_ASSERT(e.weight == 0 || e.energy->add_residuals(snake, e.weight, problem),
                  "the " + e.energy->type() + " energy has no least-squares form");
  std::function<bool(int)> callback;
  if (on_iteration)
    callback = [&](int iteration) {
      snake.positions() = problem.positions();
      return on_iteration(iteration);
    };
  const GlobalSolveSummary summary = problem.solve(options_, callback);
  snake.positions() = problem.positions();
  return summary;
}

template <int D>
EvolveSummary GlobalSolver<D>::run(Snake<D>& snake, std::vector<Phase<D>>& phases) {
  EvolveSummary summary;
  solves_.assign(phases.size(), {});
  RemeshContext<D> remesh_context;
  remesh_context.tmpl = context_.tmpl;
  remesh_context.image = context_.image;
  for (size_t p = 0; p < phases.size(); ++p) {
    Phase<D>& phase = phases[p];
    apply_phase_weights(energies_, base_weights_, phase.weights);
    PhaseSummary ps;
    const int rounds = phase.remeshers.empty() ? 0 : std::max(0, options_.remesh_rounds);
    std::vector<RemeshReport> last_reports(phase.remeshers.size());
    PointList<D> previous = snake.positions();
    for (int round = 0; round <= rounds; ++round) {
      if (round > 0) {  // remesh at the point of the phase's schedule this round stands for
        remesh_context.phase_iterations = phase.iterations;
        remesh_context.phase_iteration = std::max(1, phase.iterations * round / (rounds + 1));
        last_reports = run_remeshers(phase, snake, remesh_context);
        for (const auto& report : last_reports)
          for (auto* o : observers_) o->on_remesh(report, snake);
        previous = snake.positions();
      }
      const auto on_iteration = [&](int ceres_iteration) {
        if (ceres_iteration == 0) return true;  // Ceres reports its start as iteration 0
        ++summary.iterations;
        ++ps.iterations;
        IterationInfo info;
        info.phase = int(p);
        info.iteration = summary.iterations;
        info.phase_iteration = ps.iterations;
        double move = 0.0;
        for (int v = 0; v < snake.num_vertices(); ++v) {
          const double d = (snake.positions()[v] - previous[v]).norm();
          move = std::isfinite(d) ? std::max(move, d) : INFINITY;
        }
        previous = snake.positions();
        info.max_displacement = move;
        ps.last_displacement = move;
        info.energy_terms = energy_terms(snake);
        for (double t : info.energy_terms)
          if (std::isfinite(t)) info.total_energy += t;
        info.vertices = snake.num_vertices();
        for (auto* o : observers_) o->on_iteration(info, snake);
        return std::isfinite(move);
      };
      const GlobalSolveSummary s = solve(snake, on_iteration);
      solves_[p].push_back(s);
      const bool finite = std::all_of(snake.positions().begin(), snake.positions().end(),
                                      [](const Point<D>& x) { return x.allFinite(); });
      if (!finite || !s.usable) {
        ps.status = EvolveStatus::kDiverged;
        break;
      }
      ps.status = s.termination == "convergence" ? EvolveStatus::kConverged : EvolveStatus::kIterationBudget;
    }
    for (const auto& r : last_reports)
      if (!r.stage.empty()) ps.remesh_reports.push_back(r);
    summary.status = ps.status;
    summary.phases.push_back(ps);
    for (auto* o : observers_) o->on_phase_end(int(p), ps, snake);
    if (ps.status == EvolveStatus::kDiverged) break;
  }
  return summary;
}

template class GlobalSolver<2>;
template class GlobalSolver<3>;

}  // namespace dsnake
