#include "framework/global/global_solver.h"

#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dsnake {

// Builds E = sum_e w_e E_e as residual blocks at the snake's positions and minimises it.
template <int D>
GlobalSolveSummary GlobalSolve<D>::solve(PhaseDriver<D>& driver, Snake<D>& snake,
                                         const std::function<bool(int)>& on_iteration,
                                         const std::optional<GlobalSolverOptions>& options) {
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
  const GlobalSolveSummary summary = problem.solve(options ? *options : options_, callback);
  snake.positions() = problem.positions();
  return summary;
}

namespace {

// The largest move of any vertex since `previous` (infinite if any is not finite) and the first
// vertex that made it; updates `previous`.
template <int D>
double largest_move(const Snake<D>& snake, PointList<D>& previous, int& vertex) {
  double move = 0.0;
  vertex = snake.num_vertices() > 0 ? 0 : -1;
  for (int v = 0; v < snake.num_vertices(); ++v) {
    double d = (snake.positions()[v] - previous[v]).norm();
    if (!std::isfinite(d)) d = INFINITY;
    if (d > move) move = d, vertex = v;
  }
  previous = snake.positions();
  return move;
}

}  // namespace

template <int D>
PhaseSummary GlobalSolve<D>::run_phase(PhaseDriver<D>& driver, Snake<D>& snake, const Phase<D>& phase, int phase_index) {
  if (phase_index == 0) {
    solves_.clear();
    start_ = std::chrono::steady_clock::now();
  }
  solves_.resize(phase_index + 1);
  PhaseSummary ps;
  const int rounds = phase.remesher ? std::max(0, options_.remesh_rounds) : 0;
  std::vector<RemeshReport> last_reports;
  PointList<D> previous = snake.positions();
  auto stop = [&](Divergence d) {
    ps.status = EvolveStatus::kDiverged;
    ps.divergence = std::move(d);
  };
  for (int round = 0; round <= rounds && !ps.divergence; ++round) {
    if (round > 0) {  // remesh at the point of the phase's schedule this round stands for
      last_reports = driver.remesh(snake, phase, std::max(1, phase.iterations * round / (rounds + 1)));
      if (auto d = driver.check_vertex_budget(snake, last_reports, ps.iterations)) {
        stop(*d);
        break;
      }
      previous = snake.positions();
    }
    // The time left of max_time_s, for this solve (Ceres checks it after each iteration).
    GlobalSolverOptions options = options_;
    options.max_time_s = options_.max_time_s - elapsed_s();
    if (!(options.max_time_s > 0)) {
      stop(time_bound(ps.iterations));
      break;
    }
    PointList<D> last_good = snake.positions();  // of the last iteration that passed the watchdog
    std::optional<Divergence> watchdog;
    const auto on_iteration = [&](int ceres_iteration) {
      if (ceres_iteration == 0) return true;  // Ceres reports its start as iteration 0
      IterationInfo info;
      info.phase = phase_index;
      info.phase_iteration = ++ps.iterations;
      int vertex = -1;
      info.max_displacement = ps.last_displacement = largest_move(snake, previous, vertex);
      // The watchdog, as in the snake iteration: the iteration that fails is undone (and
      // reported at the positions that passed), and the solve stops.
      watchdog = driver.check_move(info.max_displacement, vertex, info.phase_iteration);
      if (!watchdog) watchdog = driver.check_collapse(snake, info.phase_iteration);
      if (watchdog) snake.positions() = last_good;
      info.energy_terms = driver.energy_terms(snake);
      for (double t : info.energy_terms)
        if (std::isfinite(t)) info.total_energy += t;
      driver.report(info, snake);
      if (watchdog) return false;
      last_good = snake.positions();
      return true;
    };
    const GlobalSolveSummary s = solve(driver, snake, on_iteration, options);
    solves_[phase_index].push_back(s);
    if (watchdog) {
      snake.positions() = last_good;
      if (watchdog->term.empty()) watchdog->term = "global";
      stop(*watchdog);
      break;
    }
    const bool finite = std::all_of(snake.positions().begin(), snake.positions().end(),
                                    [](const Point<D>& x) { return x.allFinite(); });
    if (!finite || !s.usable) {
      ps.status = EvolveStatus::kDiverged;
      break;
    }
    if (s.termination != "convergence" && elapsed_s() >= options_.max_time_s) {
      stop(time_bound(ps.iterations));
      break;
    }
    ps.status = s.termination == "convergence" ? EvolveStatus::kConverged : EvolveStatus::kIterationBudget;
  }
  for (const auto& r : last_reports)
    if (!r.stage.empty()) ps.remesh_reports.push_back(r);
  return ps;
}

template <int D>
double GlobalSolve<D>::elapsed_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

template <int D>
Divergence GlobalSolve<D>::time_bound(int phase_iteration) const {
  char text[160];
  std::snprintf(text, sizeof text, "the global solve reached global.max_time_s (%g s) after %d Ceres iterations of this phase",
                options_.max_time_s, phase_iteration);
  Divergence d;
  d.reason = text;
  d.phase_iteration = phase_iteration;
  d.term = "global";
  return d;
}

template class GlobalSolve<2>;
template class GlobalSolve<3>;

}  // namespace dsnake
