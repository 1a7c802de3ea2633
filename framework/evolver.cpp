#include "framework/evolver.h"

#include "framework/errors.h"

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
Evolver<D>::Evolver(EnergyContext<D> context, std::vector<WeightedEnergy<D>> energies)
    : context_(context), energies_(std::move(energies)) {
  DSNAKE_ASSERT(!energies_.empty(), "at least one energy");
  for (const auto& e : energies_) {
    DSNAKE_ASSERT(e.weight > 0 && e.energy, "positive weight");
    base_weights_.push_back(e.weight);
  }
  proposals_.resize(energies_.size());
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
void Evolver<D>::bind_if_needed(const Snake<D>& snake) {
  if (bound_snake_ == &snake && bound_version_ == snake.topology_version()) return;
  for (auto& e : energies_) e.energy->bind(context_, snake);
  bound_snake_ = &snake;
  bound_version_ = snake.topology_version();
  for (auto& p : proposals_) p.assign(snake.num_vertices(), Point<D>::Zero());
  next_.assign(snake.num_vertices(), Point<D>::Zero());
}

template <int D>
double Evolver<D>::step(Snake<D>& snake) {
  bind_if_needed(snake);
  const int n = snake.num_vertices();
  for (size_t e = 0; e < energies_.size(); ++e)
    if (energies_[e].weight > 0) energies_[e].energy->propose(snake, proposals_[e]);

  // Weighted average over the energies that govern each vertex (§3.1, §6).
  double max_move = 0.0;
  auto& q = snake.positions();
#pragma omp parallel for reduction(max : max_move) schedule(static) if (n >= 256)
  for (int v = 0; v < n; ++v) {
    Point<D> sum = Point<D>::Zero();
    double weight = 0.0;
    const bool deformation = snake.is_deformation_vertex(v);
    for (size_t e = 0; e < energies_.size(); ++e) {
      if (energies_[e].weight == 0) continue;  // switched off for this phase
      if (!deformation && energies_[e].energy->governs() == Governs::kDeformationVertices) continue;
      sum += energies_[e].weight * proposals_[e][v];
      weight += energies_[e].weight;
    }
    next_[v] = weight > 0 ? Point<D>(sum / weight) : q[v];
    const double move = (next_[v] - q[v]).norm();
    max_move = std::isfinite(move) ? std::max(max_move, move) : INFINITY;
  }
  q.swap(next_);
  return max_move;
}

template <int D>
std::vector<RemeshReport> run_remeshers(const Phase<D>& phase, Snake<D>& snake, const RemeshContext<D>& context) {
  if (phase.remesh_pass) return phase.remesh_pass(phase.remeshers, snake, context);
  std::vector<RemeshReport> reports;
  for (const auto& r : phase.remeshers) reports.push_back(r->apply(snake, context));
  return reports;
}

template std::vector<RemeshReport> run_remeshers<2>(const Phase<2>&, Snake<2>&, const RemeshContext<2>&);
template std::vector<RemeshReport> run_remeshers<3>(const Phase<3>&, Snake<3>&, const RemeshContext<3>&);

template <int D>
std::vector<double> weighted_energy_terms(const std::vector<WeightedEnergy<D>>& energies, const Snake<D>& snake) {
  std::vector<double> terms;
  for (const auto& e : energies) terms.push_back(e.weight > 0 ? e.weight * e.energy->value(snake) : 0.0);
  return terms;
}

template std::vector<double> weighted_energy_terms<2>(const std::vector<WeightedEnergy<2>>&, const Snake<2>&);
template std::vector<double> weighted_energy_terms<3>(const std::vector<WeightedEnergy<3>>&, const Snake<3>&);

template <int D>
std::vector<double> Evolver<D>::energy_terms(const Snake<D>& snake) {
  bind_if_needed(snake);
  return weighted_energy_terms(energies_, snake);
}

template <int D>
EvolveSummary Evolver<D>::run(Snake<D>& snake, std::vector<Phase<D>>& phases) {
  EvolveSummary summary;
  RemeshContext<D> remesh_context;
  remesh_context.tmpl = context_.tmpl;
  remesh_context.image = context_.image;
  for (size_t p = 0; p < phases.size(); ++p) {
    Phase<D>& phase = phases[p];
    apply_phase_weights(energies_, base_weights_, phase.weights);
    PhaseSummary ps;
    std::vector<RemeshReport> last_reports(phase.remeshers.size());
    for (int it = 1; it <= phase.iterations; ++it) {
      const double move = step(snake);
      ++summary.iterations;
      ps.iterations = it;
      ps.last_displacement = move;

      IterationInfo info;
      info.phase = static_cast<int>(p);
      info.iteration = summary.iterations;
      info.phase_iteration = it;
      info.max_displacement = move;
      if (trace_energy_) {
        info.energy_terms = energy_terms(snake);
        for (double t : info.energy_terms)
          if (std::isfinite(t)) info.total_energy += t;
      }
      if (!std::isfinite(move)) {
        ps.status = EvolveStatus::kDiverged;
        info.vertices = snake.num_vertices();
        for (auto* o : observers_) o->on_iteration(info, snake);
        break;
      }
      const bool converged = phase.tolerance > 0 && move < phase.tolerance;
      if (!phase.remeshers.empty() && !converged && it % std::max(1, phase.every) == 0) {
        remesh_context.phase_iteration = it;
        remesh_context.phase_iterations = phase.iterations;
        last_reports = run_remeshers(phase, snake, remesh_context);
        for (const auto& report : last_reports)
          for (auto* o : observers_) o->on_remesh(report, snake);
      }
      info.vertices = snake.num_vertices();
      for (auto* o : observers_) o->on_iteration(info, snake);
      if (converged) {
        ps.status = EvolveStatus::kConverged;
        break;
      }
    }
    for (const auto& r : last_reports)
      if (!r.stage.empty()) ps.remesh_reports.push_back(r);
    summary.status = ps.status;
    summary.phases.push_back(ps);
    for (auto* o : observers_) o->on_phase_end(static_cast<int>(p), ps, snake);
    if (ps.status == EvolveStatus::kDiverged) break;
  }
  return summary;
}

template class Evolver<2>;
template class Evolver<3>;

}  // namespace dsnake
