// External fields on the paper's volume size (230 x 300 x 80 voxels, a smooth ellipsoid) and
// a 512^2 disk, edge map blurred with sigma = 1: explicit GVF (100 iterations, mu = 0.2),
// converged multigrid GVF (relative residual 1e-4), converged DDGVF, VFC (R = 32) and the
// distance field; the second argument of each benchmark is the thread count.
// Run: build/release/experiments/bench/bench_fields --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include "fields/ddgvf.h"
#include "fields/distance.h"
#include "fields/edge_map.h"
#include "fields/gvf.h"
#include "framework/numerics/diffusion_grid.h"
#include "framework/numerics/grid_diffusion_solver.h"
#include "fields/vfc.h"

#include "experiments/bench/bench_images.h"

#include <benchmark/benchmark.h>
#include <cmath>
#include <omp.h>

namespace dsnake {
namespace {

using bench::object_image;

// The GVF system of the object's edge map (b = |grad f|^2, c = grad f), built once.
template <int D>
struct GvfSystem {
  EdgeMap<D> edges;
  std::vector<float> b;
  GvfSystem() : edges(compute_edge_map(object_image<D>(), EdgeMapOptions{}, false, "gvf")) {
    b.assign(edges.f.size(), 0.f);
    for (size_t l = 0; l < b.size(); ++l)
      for (int a = 0; a < D; ++a) b[l] += edges.grad_f[a][l] * edges.grad_f[a][l];
  }
};
template <int D>
const GvfSystem<D>& gvf_system() {
  static const GvfSystem<D> system;
  return system;
}

// Solves the GVF system from v = grad f with the given solver options (the edge map excluded).
template <int D>
void run_solver(benchmark::State& state, const GvfSolveOptions& o) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  const GvfSystem<D>& s = gvf_system<D>();
  std::array<std::vector<float>, D> v;
  std::vector<const std::vector<float>*> c;
  std::vector<std::vector<float>*> out;
  for (int a = 0; a < D; ++a) c.push_back(&s.edges.grad_f[a]), out.push_back(&v[a]);
  GvfSolveStats stats;
  for (auto _ : state) {
    for (int a = 0; a < D; ++a) v[a] = s.edges.grad_f[a];
    stats = solve_gvf(s.edges.grid, s.b, c, out, o);
  }
  state.counters["iterations"] = stats.iterations;
  state.counters["rel_residual"] = stats.relative_residual;
}

void BM_GvfExplicit100_3d(benchmark::State& state) {
  GvfSolveOptions o;
  o.solver = GvfSolver::kExplicit, o.mu = 0.2, o.iterations = 100, o.tolerance = 0;
  run_solver<3>(state, o);
}
BENCHMARK(BM_GvfExplicit100_3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GvfExplicit100_2d(benchmark::State& state) {
  GvfSolveOptions o;
  o.solver = GvfSolver::kExplicit, o.mu = 0.2, o.iterations = 100, o.tolerance = 0;
  run_solver<2>(state, o);
}
BENCHMARK(BM_GvfExplicit100_2d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// The explicit 2D solve at a given wavefront depth (range 1; 1 = the plain double-buffered loop),
// through the solver's internal entry point: does the depth (the rows' way through the caches)
// matter?
void BM_GvfExplicitDepth2d(benchmark::State& state) {
  omp_set_num_threads(1);
  const GvfSystem<2>& s = gvf_system<2>();
  const gvf_detail::Level L = gvf_detail::level_of(s.edges.grid);
  std::array<std::vector<float>, 2> v;
  std::vector<const std::vector<float>*> c;
  std::vector<std::vector<float>*> out;
  for (int a = 0; a < 2; ++a) c.push_back(&s.edges.grad_f[a]), out.push_back(&v[a]);
  GvfSolveOptions o;
  o.solver = GvfSolver::kExplicit, o.mu = 0.2, o.iterations = 100, o.tolerance = 0;
  for (auto _ : state) {
    for (int a = 0; a < 2; ++a) v[a] = s.edges.grad_f[a];
    // (The rhs norm only scales the reported residual; tolerance 0 runs all 100 iterations.)
    gvf_detail::solve_explicit(L, s.b, c, out, o, 1.0, static_cast<int>(state.range(0)));
  }
}
BENCHMARK(BM_GvfExplicitDepth2d)->Arg(1)->Arg(2)->Arg(4)->Arg(10)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GvfMultigridConverged3d(benchmark::State& state) {
  GvfSolveOptions o;
  o.solver = GvfSolver::kMultigrid, o.mu = 0.2, o.tolerance = 1e-4;
  run_solver<3>(state, o);
}
BENCHMARK(BM_GvfMultigridConverged3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GvfMultigridConverged2d(benchmark::State& state) {
  GvfSolveOptions o;
  o.solver = GvfSolver::kMultigrid, o.mu = 0.2, o.tolerance = 1e-4;
  run_solver<2>(state, o);
}
BENCHMARK(BM_GvfMultigridConverged2d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_EdgeMap3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(compute_edge_map(object_image<3>(), EdgeMapOptions{}, false, "gvf"));
}
BENCHMARK(BM_EdgeMap3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GvfField3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  GvfField<3> field;
  for (auto _ : state) field.compute(object_image<3>());
  state.counters["cycles"] = field.stats().iterations;
}
BENCHMARK(BM_GvfField3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DdgvfField3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  DdgvfField<3> field;
  for (auto _ : state) field.compute(object_image<3>());
}
BENCHMARK(BM_DdgvfField3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_VfcField3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  VfcFieldOptions o;
  o.radius = 32;
  VfcField<3> field(o);
  for (auto _ : state) field.compute(object_image<3>());
  state.counters["plan_s"] = field.timings().plan_s;
  state.counters["kernel_s"] = field.timings().kernel_s;
  state.counters["convolve_s"] = field.timings().convolve_s;
}
BENCHMARK(BM_VfcField3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DistanceField3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  DistanceField<3> field;
  for (auto _ : state) field.compute(object_image<3>());
}
BENCHMARK(BM_DistanceField3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
