#include "framework/core/evolver.h"

#include "framework/core/errors.h"
#include "framework/core/stall.h"

#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {

template <int D>
double largest_move(const PointList<D>& from, const PointList<D>& to) {
  double max_move = 0.0;
  const int n = static_cast<int>(from.size());
#pragma omp parallel for reduction(max : max_move) schedule(static) if (n >= 256)
  for (int v = 0; v < n; ++v) max_move = std::max(max_move, (to[v] - from[v]).norm());
  return max_move;
}

}  // namespace

template <int D>
double SnakeStep<D>::step(PhaseDriver<D>& driver, Snake<D>& snake) {
  driver.bind(snake);
  auto& energies = driver.energies();
  const int n = snake.num_vertices();
  proposals_.resize(energies.size());
  for (auto& p : proposals_) p.resize(n, Point<D>::Zero());
  next_.resize(n, Point<D>::Zero());
  governs_.resize(energies.size());
  masks_.resize(energies.size());
  for (size_t e = 0; e < energies.size(); ++e) {
    if (energies[e].weight > 0) energies[e].energy->propose(snake, proposals_[e]);
    governs_[e] = energies[e].energy->governs();
    masks_[e] = energies[e].energy->governed_mask();
    DSNAKE_ASSERT(governs_[e] != Governs::kMarkedVertices || int(masks_[e].size()) == n,
                  "a marked-vertex energy's mask has one flag per snake vertex");
  }

  // Weighted average over the energies that govern each vertex (§3.1, §6).
  double max_move = 0.0;
  auto& q = snake.positions();
  moves_.resize(n);
#pragma omp parallel for reduction(max : max_move) schedule(static) if (n >= 256)
  for (int v = 0; v < n; ++v) {
    Point<D> sum = Point<D>::Zero();
    double weight = 0.0;
    const bool deformation = snake.is_deformation_vertex(v);
    for (size_t e = 0; e < energies.size(); ++e) {
      if (energies[e].weight == 0) continue;  // switched off for this phase
      if (!deformation && governs_[e] == Governs::kDeformationVertices) continue;
      if (governs_[e] == Governs::kMarkedVertices && !masks_[e][v]) continue;
      sum += energies[e].weight * proposals_[e][v];
      weight += energies[e].weight;
    }
    next_[v] = weight > 0 ? Point<D>(sum / weight) : q[v];
    const double move = (next_[v] - q[v]).norm();
    moves_[v] = std::isfinite(move) ? move : INFINITY;
    max_move = std::max(max_move, moves_[v]);
  }
  // The first vertex with the largest move (serial: the same vertex for any thread count).
  worst_vertex_ = n > 0 ? static_cast<int>(std::max_element(moves_.begin(), moves_.end()) - moves_.begin()) : -1;
  // The move guard sees only steps the watchdog passes: a diverged step (a move not finite, or
  // past watchdog.max_move) is reported as it is, not shortened into a still snake (shortening
  // proposals a billion mm long, every iteration, would test every pair of facets).
  if (MoveGuard<D>* guard = driver.move_guard(); guard && !driver.check_move(max_move, worst_vertex_, 0)) {
    const MoveGuardReport r = guard->guard(snake, next_);
    guard_report_ += r;
    if (r.shortened + r.refused > 0) max_move = largest_move(q, next_);
  }
  q.swap(next_);
  return max_move;
}

template <int D>
int SnakeStep<D>::blame_term(const Snake<D>& snake_before, int vertex) const {
  if (vertex < 0 || vertex >= snake_before.num_vertices()) return -1;
  const Point<D>& from = snake_before.positions()[vertex];
  int worst = -1;
  double farthest = -1;
  for (size_t e = 0; e < proposals_.size(); ++e) {
    if (int(proposals_[e].size()) <= vertex) continue;
    const double d = (proposals_[e][vertex] - from).norm();
    const double key = std::isfinite(d) ? d : INFINITY;
    if (key > farthest) farthest = key, worst = static_cast<int>(e);
  }
  return worst;
}

template <int D>
int SnakeStep<D>::blame_collapse(PhaseDriver<D>& driver, const Snake<D>& snake_before) const {
  const int n = snake_before.num_vertices();
  Snake<D> alone = snake_before;
  int worst = -1;
  double smallest = INFINITY;
  for (size_t e = 0; e < proposals_.size(); ++e) {
    if (int(proposals_[e].size()) != n || !(driver.energies()[e].weight > 0)) continue;  // (off: no proposal)
    alone.positions() = snake_before.positions();
    for (int v = 0; v < n; ++v) {
      const bool governed = governs_[e] == Governs::kAllVertices ||
                            (governs_[e] == Governs::kDeformationVertices && snake_before.is_deformation_vertex(v)) ||
                            (governs_[e] == Governs::kMarkedVertices && masks_[e][v]);
      if (governed) alone.positions()[v] = proposals_[e][v];
    }
    const double measure = std::abs(snake_before.signed_measure()) > 0
                               ? alone.signed_measure() / snake_before.signed_measure() : alone.signed_measure();
    const double key = std::isfinite(measure) ? measure : -INFINITY;
    if (key < smallest) smallest = key, worst = static_cast<int>(e);
  }
  return worst;
}

template <int D>
PhaseSummary SnakeStep<D>::run_phase(PhaseDriver<D>& driver, Snake<D>& snake, const Phase<D>& phase, int phase_index) {
  PhaseSummary ps;
  guard_report_ = {};
  std::vector<RemeshReport> last_reports;
  const int window = phase.tolerance > 0 ? phase.window : 0;
  StallDetector<D> stall(window, phase.tolerance, phase.energy_tolerance, phase.stop_when_worse);
  if (window > 0) stall.start(snake, driver.energy_terms(snake));
  std::vector<double> weights;
  for (const auto& e : driver.energies()) weights.push_back(e.weight);
  for (int it = 1; it <= phase.iterations; ++it) {
    const double move = step(driver, snake);
    ps.iterations = it;
    ps.last_displacement = move;
    IterationInfo info;
    info.phase = phase_index;
    info.phase_iteration = it;
    info.max_displacement = move;
    // The watchdog: a move too large (or not finite), else a collapse. The iteration is undone:
    // back to the last positions that passed (next_ holds them after the swap in step()).
    std::optional<Divergence> d = driver.check_move(move, worst_vertex_, it);
    const bool collapse = !d && (d = driver.check_collapse(snake, it)).has_value();
    if (d) {
      snake.positions().swap(next_);
      d->term_index = collapse ? blame_collapse(driver, snake) : blame_term(snake, worst_vertex_);
      if (d->term_index >= 0) d->term = driver.energies()[d->term_index].energy->type();
      ps.status = EvolveStatus::kDiverged;
      ps.divergence = d;
      if (driver.trace_energy()) {
        info.energy_terms = driver.energy_terms(snake);
        info.total_energy = finite_total(info.energy_terms);
      }
      driver.report(info, snake);
      break;
    }
    if (driver.trace_energy()) {
      info.energy_terms = driver.energy_terms(snake);
      info.total_energy = finite_total(info.energy_terms);
    }
    bool converged = phase.tolerance > 0 && move < phase.tolerance;
    if (converged) ps.converged_on = "displacement";
    if (!converged && window > 0 && it % window == 0) {
      const std::vector<double> terms = driver.trace_energy() ? info.energy_terms : driver.energy_terms(snake);
      const WindowEnd end = stall.close(it, snake, terms, weights, move);
      if (end == WindowEnd::kWorse) {
        snake = stall.checkpoint();  // the window's start was better by every measure: end there
        ps.converged_on = "worse";
        ps.last_displacement = stall.checkpoint_move();
        if (driver.trace_energy()) {
          info.energy_terms = stall.checkpoint_terms();
          info.total_energy = finite_total(info.energy_terms);
        }
      } else {
        ps.centroid_rate = stall.centroid_rate();
        if (end == WindowEnd::kStill) ps.converged_on = "window";
      }
      converged = end == WindowEnd::kWorse || end == WindowEnd::kStill;
    }
    if (phase.remesher && !converged && it % std::max(1, phase.every) == 0) last_reports = driver.remesh(snake, phase, it);
    driver.report(info, snake);
    if (std::optional<Divergence> d = driver.check_vertex_budget(snake, last_reports, it)) {
      ps.status = EvolveStatus::kDiverged;
      ps.divergence = d;
      break;
    }
    if (converged) {
      ps.status = EvolveStatus::kConverged;
      break;
    }
  }
  for (const auto& r : last_reports)
    if (!r.stage.empty()) ps.remesh_reports.push_back(r);
  ps.move_guard = guard_report_;
  return ps;
}

template class SnakeStep<2>;
template class SnakeStep<3>;

}  // namespace dsnake
