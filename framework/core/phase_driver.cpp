#include "framework/core/phase_driver.h"

#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dsnake {

std::string to_string(EvolveStatus status) {
  switch (status) {
    case EvolveStatus::kConverged: return "converged";
    case EvolveStatus::kIterationBudget: return "iteration_budget";
    case EvolveStatus::kDiverged: return "diverged";
  }
  return "unknown";
}

template <int D>
void apply_phase_weights(std::vector<WeightedEnergy<D>>& energies, const std::vector<double>& base,
                         const std::vector<double>& phase_weights) {
  DSNAKE_ASSERT(phase_weights.empty() || phase_weights.size() == energies.size(), "one weight per energy");
  for (size_t e = 0; e < energies.size(); ++e) {
    energies[e].weight = phase_weights.empty() ? base[e] : phase_weights[e];
    DSNAKE_ASSERT(energies[e].weight >= 0, "non-negative weight");
  }
}

template void apply_phase_weights<2>(std::vector<WeightedEnergy<2>>&, const std::vector<double>&, const std::vector<double>&);
template void apply_phase_weights<3>(std::vector<WeightedEnergy<3>>&, const std::vector<double>&, const std::vector<double>&);

template <int D>
std::vector<double> weighted_energy_terms(const std::vector<WeightedEnergy<D>>& energies, const Snake<D>& snake) {
  std::vector<double> terms;
  for (const auto& e : energies) terms.push_back(e.weight > 0 ? e.weight * e.energy->value(snake) : 0.0);
  return terms;
}

template std::vector<double> weighted_energy_terms<2>(const std::vector<WeightedEnergy<2>>&, const Snake<2>&);
template std::vector<double> weighted_energy_terms<3>(const std::vector<WeightedEnergy<3>>&, const Snake<3>&);

template <int D>
PhaseDriver<D>::PhaseDriver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies,
                            std::unique_ptr<Minimizer<D>> minimizer)
    : context_(context), energies_(std::move(energies)), minimizer_(std::move(minimizer)) {
  DSNAKE_ASSERT(!energies_.empty(), "at least one energy");
  DSNAKE_ASSERT(minimizer_ != nullptr, "a minimizer");
  for (const auto& e : energies_) {
    DSNAKE_ASSERT(e.weight > 0 && e.energy, "positive weight");
    base_weights_.push_back(e.weight);
  }
}

template <int D>
void PhaseDriver<D>::bind(const Snake<D>& snake) {
  if (bound_snake_ == &snake && bound_version_ == snake.topology_version() && bound_vertices_ == snake.num_vertices())
    return;
  for (auto& e : energies_) e.energy->bind(context_, snake);
  bound_snake_ = &snake;
  bound_version_ = snake.topology_version();
  bound_vertices_ = snake.num_vertices();
}

template <int D>
std::vector<double> PhaseDriver<D>::energy_terms(const Snake<D>& snake) {
  bind(snake);
  return weighted_energy_terms(energies_, snake);
}

template <int D>
std::vector<RemeshReport> PhaseDriver<D>::remesh(Snake<D>& snake, const Phase<D>& phase, int phase_iteration) {
  RemeshContext<D> remesh_context;
  remesh_context.tmpl = context_.tmpl;
  remesh_context.image = context_.image;
  remesh_context.phase_iteration = phase_iteration;
  remesh_context.phase_iterations = phase.iterations;
  remesh_context.max_vertices = watchdog_.max_vertices;
  std::vector<RemeshReport> reports = phase.remesher->apply_stages(snake, remesh_context);
  for (const auto& report : reports)
    for (auto* o : observers_) o->on_remesh(report, snake);
  bind(snake);
  return reports;
}

template <int D>
void PhaseDriver<D>::report(IterationInfo& info, const Snake<D>& snake) {
  info.iteration = ++iterations_;
  info.vertices = snake.num_vertices();
  for (auto* o : observers_) o->on_iteration(info, snake);
}

template <int D>
double PhaseDriver<D>::size_share(const Snake<D>& snake) const {
  return snake.signed_measure() / start_measure_;
}

template <int D>
std::optional<Divergence> PhaseDriver<D>::check_move(double move, int vertex, int phase_iteration) const {
  if (std::isfinite(move) && (!(watchdog_.max_move > 0) || move <= watchdog_.max_move)) return std::nullopt;
  Divergence d;
  d.reason = std::isfinite(move) ? "a vertex moved more than watchdog.max_move in one iteration"
                                 : "a vertex moved by a non-finite amount";
  d.phase_iteration = phase_iteration;
  d.vertex = vertex;
  d.move = move;
  return d;
}

template <int D>
std::optional<Divergence> PhaseDriver<D>::check_collapse(const Snake<D>& snake, int phase_iteration) const {
  // Off, or a start without an enclosed area (no share to compare).
  if (!(watchdog_.min_size > 0) || !(std::abs(start_measure_) > 0) || !std::isfinite(start_measure_)) return std::nullopt;
  const double share = size_share(snake);
  if (share >= watchdog_.min_size) return std::nullopt;  // (NaN fails too: non-finite positions)
  char text[160];
  std::snprintf(text, sizeof text, "the snake collapsed: its enclosed %s fell to %.3g of the start's, below watchdog.min_size (%g)",
                D == 2 ? "area" : "volume", share, watchdog_.min_size);
  Divergence d;
  d.reason = text;
  d.phase_iteration = phase_iteration;
  d.term = "collapse";
  d.size_share = share;
  return d;
}

template <int D>
std::optional<Divergence> PhaseDriver<D>::check_vertex_budget(const Snake<D>& snake, const std::vector<RemeshReport>& reports,
                                                              int phase_iteration) const {
  std::string stage;
  for (const auto& r : reports)
    if (r.over_budget) stage = r.stage;
  if (stage.empty() && snake.num_vertices() <= watchdog_.max_vertices) return std::nullopt;
  Divergence d;
  d.reason = stage.empty() ? "remeshing left " + std::to_string(snake.num_vertices()) + " vertices, more than watchdog.max_vertices"
                           : "remeshing (" + stage + ") would leave more than watchdog.max_vertices (" +
                                 std::to_string(watchdog_.max_vertices) + ") vertices";
  d.phase_iteration = phase_iteration;
  d.term = "remesh";
  return d;
}

template <int D>
EvolveSummary PhaseDriver<D>::run(Snake<D>& snake, std::vector<Phase<D>>& phases) {
  EvolveSummary summary;
  iterations_ = 0;
  start_measure_ = snake.signed_measure();
  for (size_t p = 0; p < phases.size(); ++p) {
    apply_phase_weights(energies_, base_weights_, phases[p].weights);
    bind(snake);
    for (auto& e : energies_) e.energy->begin_phase(snake);
    PhaseSummary ps = minimizer_->run_phase(*this, snake, phases[p], static_cast<int>(p));
    summary.status = ps.status;
    summary.phases.push_back(ps);
    for (auto* o : observers_) o->on_phase_end(static_cast<int>(p), ps, snake);
    if (ps.status == EvolveStatus::kDiverged) break;
  }
  summary.iterations = iterations_;
  return summary;
}

template class PhaseDriver<2>;
template class PhaseDriver<3>;

}  // namespace dsnake
