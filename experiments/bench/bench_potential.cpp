// Potentials for the global solve (fields/smooth_potential.h): the least-squares integration of a
// field ("integrated", DCT Poisson solve) on the paper's volume size (230 x 300 x 80 voxels, a
// smooth ellipsoid, the force being the gradient field grad f of its edge map, sigma = 1) and
// on a 512^2 disk; and one evaluation of the smooth interpolant (value and gradient) at random
// points, cubic and linear, 2D and 3D. The second argument of the integration benchmarks is
// the thread count.
// Run: build/release/experiments/bench/bench_potential --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include "fields/gradient.h"
#include "fields/smooth_potential.h"

#include "experiments/bench/bench_images.h"

#include <benchmark/benchmark.h>
#include <cmath>
#include <omp.h>
#include <random>

namespace dsnake {
namespace {

using bench::object_image;

// The edge-map gradient field of the object, computed once.
template <int D>
const GradientField<D>& object_field() {
  static const GradientField<D> field = [] {
    GradientField<D> f;
    f.compute(object_image<D>());
    return f;
  }();
  return field;
}

template <int D>
void BM_IntegratedPotential(benchmark::State& state) {
  const Image<D>& image = object_image<D>();
  const GradientField<D>& field = object_field<D>();
  const int threads = omp_get_max_threads();
  omp_set_num_threads(int(state.range(1)));
  PotentialOptions o;
  o.type = PotentialType::kIntegrated;
  for (auto _ : state) benchmark::DoNotOptimize(compute_potential<D>(o, image, &field).data().data());
  omp_set_num_threads(threads);
  state.counters["voxels"] = double(image.num_voxels());
}
BENCHMARK_TEMPLATE(BM_IntegratedPotential, 3)->Args({3, 1})->Args({3, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_IntegratedPotential, 2)->Args({2, 1})->Args({2, 2})->Unit(benchmark::kMillisecond)->UseRealTime();

// One value_and_gradient at a random point of a random 64^D grid; range(0): 0 cubic, 1 linear.
template <int D>
void BM_SmoothPotentialEvaluate(benchmark::State& state) {
  Grid<D> grid;
  grid.size = GridIndex<D>::Constant(64);
  grid.spacing = Point<D>::Ones();
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<double> values(grid.num_voxels());
  for (double& v : values) v = unit(rng);
  const SmoothPotential<D> p(grid, values, state.range(0) == 0 ? "cubic" : "linear");
  std::vector<Point<D>> points(4096);
  for (Point<D>& x : points)
    for (int a = 0; a < D; ++a) x[a] = 63 * unit(rng);
  size_t i = 0;
  Point<D> g;
  for (auto _ : state) {
    benchmark::DoNotOptimize(p.value_and_gradient(points[i], g));
    i = (i + 1) & 4095;
  }
}
BENCHMARK_TEMPLATE(BM_SmoothPotentialEvaluate, 2)->Arg(0)->Arg(1);
BENCHMARK_TEMPLATE(BM_SmoothPotentialEvaluate, 3)->Arg(0)->Arg(1);

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
