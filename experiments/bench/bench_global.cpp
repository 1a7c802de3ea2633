// The global-solve baseline against the snake on the 3D star of Figs. 13-18: the
// D-Snake energy (external kappa 0.1 on the integrated GVF potential, approximate ASAP eta 0.5
// over 2-ring neighbourhoods) on the star template subdivided 0, 2, 3 and 4 times (26, 386,
// 1538 and 6146 vertices; sizes of 2000 and 7000 fall between subdivision levels), started a
// similarity away from the truth (experiments/ablation/global/star_clean.json).
//  - BM_GlobalSolve: one Ceres solve (at most 100 iterations; linear solver 0 sparse normal
//    Cholesky, 1 sparse Schur eliminating the per-vertex similarities, 2 CGNR); counters: Ceres iterations,
//    residual evaluations, and the final mean surface distance to the true star (msd).
//  - BM_Snake: the snake from the same start until its largest move is below 1e-3 (at most 500
//    iterations); counters: iterations and msd.
// Run: build/release/experiments/bench/bench_global --benchmark_repetitions=3
//        --benchmark_report_aggregates_only=true
#include "experiments/spec/experiment.h"
#include "fields/smooth_potential.h"
#include "framework/core/evolver.h"
#include "framework/global/global_solver.h"
#include "framework/metrics/metrics.h"

#include <benchmark/benchmark.h>
#include <map>
#include <omp.h>

#ifndef DSNAKE_SOURCE_DIR
#define DSNAKE_SOURCE_DIR "."
#endif

namespace dsnake {
namespace {

struct Case {
  ExperimentFile file;
  Experiment<3> experiment;
  std::unique_ptr<SmoothPotential<3>> potential;
};

// The star experiment with `subdivisions`, its field and potential computed once.
Case& star_case(int subdivisions) {
  static std::map<int, std::unique_ptr<Case>> cases;
  auto& c = cases[subdivisions];
  if (!c) {
    c = std::make_unique<Case>();
    c->file = load_experiment_file(std::string(DSNAKE_SOURCE_DIR) + "/experiments/ablation/global/star_clean.json",
                                   {"template.subdivisions=" + std::to_string(subdivisions),
                                    "energies[2].neighborhood=rings", "energies[2].rings=2"});
    c->experiment = make_experiment<3>(c->file);
    c->experiment.field->compute(c->experiment.image);
    c->potential = make_potential<3>(*c->experiment.potential, c->experiment.image, c->experiment.field.get());
  }
  return *c;
}

// Fresh energies for every run (they keep per-snake state).
std::vector<WeightedEnergy<3>> energies_of(const ExperimentFile& file) { return make_experiment<3>(file).energies; }

void BM_GlobalSolve(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  omp_set_num_threads(threads);
  Case& c = star_case(static_cast<int>(state.range(0)));
  const Experiment<3>& ex = c.experiment;
  GlobalSolverOptions options = ex.global;
  options.max_iterations = 100;
  options.threads = threads;
  static const char* solvers[] = {"sparse_normal_cholesky", "sparse_schur", "cgnr"};
  options.linear_solver = *enum_from_name<LinearSolver>(solvers[state.range(2)]);
  Snake<3> snake = Snake<3>::from_template(ex.tmpl, ex.initial);
  GlobalSolveSummary summary;
  for (auto _ : state) {
    state.PauseTiming();
    snake = Snake<3>::from_template(ex.tmpl, ex.initial);
    GlobalSolver<3> solver({&ex.tmpl, &ex.image, ex.field.get(), c.potential.get()}, energies_of(c.file), options);
    state.ResumeTiming();
    summary = solver.solve(snake);
  }
  state.counters["vertices"] = snake.num_vertices();
  state.counters["ceres_iterations"] = summary.iterations;
  state.counters["residual_evaluations"] = summary.residual_evaluations;
  state.counters["msd"] = compute_metrics(snake, ex.truth).mean_surface_distance.value_or(-1);
}
// The factorising solvers only up to 386 vertices: at 1538 the normal equations' supernodes
// (2-ring similarities couple 4-ring neighbourhoods) make one solve take over a minute.
BENCHMARK(BM_GlobalSolve)->ArgsProduct({{0, 2}, {1, 2}, {0, 1}})->ArgNames({"subdiv", "threads", "solver"})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_GlobalSolve)->ArgsProduct({{0, 2, 3, 4}, {1, 2}, {2}})->ArgNames({"subdiv", "threads", "solver"})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

void BM_Snake(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(1)));
  Case& c = star_case(static_cast<int>(state.range(0)));
  const Experiment<3>& ex = c.experiment;
  Snake<3> snake = Snake<3>::from_template(ex.tmpl, ex.initial);
  EvolveSummary summary;
  for (auto _ : state) {
    state.PauseTiming();
    snake = Snake<3>::from_template(ex.tmpl, ex.initial);
    Evolver<3> evolver({&ex.tmpl, &ex.image, ex.field.get()}, energies_of(c.file));
    evolver.set_trace_energy(false);
    std::vector<Phase<3>> phases(1);
    phases[0].iterations = 500;
    phases[0].tolerance = 1e-3;
    state.ResumeTiming();
    summary = evolver.run(snake, phases);
  }
  state.counters["vertices"] = snake.num_vertices();
  state.counters["iterations"] = summary.iterations;
  state.counters["msd"] = compute_metrics(snake, ex.truth).mean_surface_distance.value_or(-1);
}
BENCHMARK(BM_Snake)->ArgsProduct({{0, 2, 3, 4}, {1, 2}})->ArgNames({"subdiv", "threads"})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
