#include "framework/global/global_solver.h"

#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>

namespace dsnake {

// Builds E = sum_e w_e E_e as residual blocks at the snake's positions and minimises it.
template <int D>
GlobalSolveSummary GlobalSolve<D>::solve(PhaseDriver<D>& driver, Snake<D>& snake,
                                         const std::function<bool(int)>& on_iteration) {
  driver.bind(snake);
  GlobalProblem<D> problem(snake);
  for (const auto& e : driver.energies())
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

namespace {

// The largest move of any vertex since `previous` (infinite if any is not finite); updates it.
template <int D>
double largest_move(const Snake<D>& snake, PointList<D>& previous) {
  double move = 0.0;
  for (int v = 0; v < snake.num_vertices(); ++v) {
    const double d = (snake.positions()[v] - previous[v]).norm();
    move = std::isfinite(d) ? std::max(move, d) : INFINITY;
  }
  previous = snake.positions();
  return move;
}

}  // namespace

template <int D>
PhaseSummary GlobalSolve<D>::run_phase(PhaseDriver<D>& driver, Snake<D>& snake, const Phase<D>& phase, int phase_index) {
  if (phase_index == 0) solves_.clear();
  solves_.resize(phase_index + 1);
  PhaseSummary ps;
  const int rounds = phase.remesher ? std::max(0, options_.remesh_rounds) : 0;
  std::vector<RemeshReport> last_reports;
  PointList<D> previous = snake.positions();
  for (int round = 0; round <= rounds; ++round) {
    if (round > 0) {  // remesh at the point of the phase's schedule this round stands for
      last_reports = driver.remesh(snake, phase, std::max(1, phase.iterations * round / (rounds + 1)));
      previous = snake.positions();
    }
    const auto on_iteration = [&](int ceres_iteration) {
      if (ceres_iteration == 0) return true;  // Ceres reports its start as iteration 0
      IterationInfo info;
      info.phase = phase_index;
      info.phase_iteration = ++ps.iterations;
      info.max_displacement = ps.last_displacement = largest_move(snake, previous);
      info.energy_terms = driver.energy_terms(snake);
      for (double t : info.energy_terms)
        if (std::isfinite(t)) info.total_energy += t;
      driver.report(info, snake);
      return std::isfinite(info.max_displacement);
    };
    const GlobalSolveSummary s = solve(driver, snake, on_iteration);
    solves_[phase_index].push_back(s);
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
  return ps;
}

template class GlobalSolve<2>;
template class GlobalSolve<3>;

}  // namespace dsnake
