// Metrics on large meshes: symmetric surface distances between two offset spheres and the
// self-intersection count, at 2562 and 10242 vertices (the paper's lung ends near 7000).
// Run: build/release/experiments/bench/bench_metrics --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include "experiments/phantoms/phantoms.h"
#include "framework/metrics/metrics.h"

#include <benchmark/benchmark.h>
#include <omp.h>

namespace dsnake {
namespace {

Template<3> sphere(int subdivisions, double radius, const Point<3>& centre) {
  Template<3> t = make_icosphere(subdivisions);
  for (auto& p : t.positions) p = centre + radius * p;
  return t;
}

void BM_SurfaceDistances(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(1)));
  const Template<3> a = sphere(static_cast<int>(state.range(0)), 30, Point<3>(40, 40, 40));
  const Template<3> b = sphere(static_cast<int>(state.range(0)), 31.5, Point<3>(40.8, 39.5, 40.3));
  for (auto _ : state)
    benchmark::DoNotOptimize(surface_distances<3>({a.positions, a.connectivity}, {b.positions, b.connectivity}, 0.2));
  state.counters["vertices"] = a.num_vertices();
}
BENCHMARK(BM_SurfaceDistances)->ArgsProduct({{4, 5}, {1, 2}})->ArgNames({"subdiv", "threads"})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SelfIntersections(benchmark::State& state) {
  const Template<3> a = sphere(static_cast<int>(state.range(0)), 30, Point<3>(40, 40, 40));
  for (auto _ : state) benchmark::DoNotOptimize(count_self_intersections<3>({a.positions, a.connectivity}));
  state.counters["vertices"] = a.num_vertices();
}
BENCHMARK(BM_SelfIntersections)->Arg(4)->Arg(5)->ArgName("subdiv")->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
