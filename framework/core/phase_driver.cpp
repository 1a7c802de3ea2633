#include "framework/core/phase_driver.h"

#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>

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
EvolveSummary PhaseDriver<D>::run(Snake<D>& snake, std::vector<Phase<D>>& phases) {
  EvolveSummary summary;
  iterations_ = 0;
  for (size_t p = 0; p < phases.size(); ++p) {
    apply_phase_weights(energies_, base_weights_, phases[p].weights);
    bind(snake);
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
