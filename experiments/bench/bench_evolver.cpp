// One snake iteration (internal + external energies, averaged by the Evolver) on 2D contours
// and 3D icospheres of growing size, and the gradient field on the paper's volume size.
// Run: build/release/experiments/bench/bench_evolver --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include "energies/registry.h"
#include "experiments/phantoms/phantoms.h"
#include "fields/registry.h"
#include "framework/core/evolver.h"
#include "framework/core/image_filters.h"

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>
#include <omp.h>

namespace dsnake {
namespace {

template <int D>
std::unique_ptr<ExternalField<D>> gradient_field(const Image<D>& image) {
  const auto spec = nlohmann::json::parse(R"({"type": "gradient", "sigma": 1.0})");
  JsonReader r(spec, "bench", "field");
  auto field = field_registry<D>().create(r);
  field->compute(image);
  return field;
}

template <int D>
std::vector<WeightedEnergy<D>> classical_energies() {
  std::vector<WeightedEnergy<D>> energies;
  for (const char* text : {R"({"type": "internal", "alpha": 0.1, "beta": 0.01})", R"({"type": "external", "tau": 1.0})"}) {
    const auto spec = nlohmann::json::parse(text);
    JsonReader r(spec, "bench", "energies");
    energies.push_back({1.0, energy_registry<D>().create(r)});
  }
  return energies;
}

// A blurred sphere (radius 40) in a 128^3 volume, or a disk in 512^2.
template <int D>
Image<D> ball_image(int size, double radius) {
  Grid<D> g;
  g.size.setConstant(size);
  Image<D> img(g, 170.0f);
  const Point<D> c = Point<D>::Constant((size - 1) / 2.0);
  for (int64_t l = 0; l < g.num_voxels(); ++l)
    if ((g.to_physical(g.index(l)) - c).norm() < radius) img[l] = 85.0f;
  return gaussian_blur(img, 1.0);
}

void BM_EvolverStep3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(1)));
  static const Image<3> image = ball_image<3>(128, 40);
  static const auto field = gradient_field<3>(image);
  Template<3> t = make_icosphere(static_cast<int>(state.range(0)));
  for (auto& p : t.positions) p = Point<3>::Constant(63.5) + 50.0 * p;
  Snake<3> snake = Snake<3>::from_template(t, t.positions);
  Evolver<3> evolver({&t, &image, field.get()}, classical_energies<3>());
  evolver.step(snake);  // binds and factorises once
  for (auto _ : state) benchmark::DoNotOptimize(evolver.step(snake));
  state.counters["vertices"] = snake.num_vertices();
}
BENCHMARK(BM_EvolverStep3d)->ArgsProduct({{3, 4, 5}, {1, 2}})->ArgNames({"subdiv", "threads"})
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_EvolverStep2d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(1)));
  static const Image<2> image = ball_image<2>(512, 150);
  static const auto field = gradient_field<2>(image);
  const int n = static_cast<int>(state.range(0));
  Template<2> t;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    t.positions.emplace_back(255.5 + 180 * std::cos(a), 255.5 + 180 * std::sin(a));
  }
  t.connectivity = Connectivity::polygon(n);
  Snake<2> snake = Snake<2>::from_template(t, t.positions);
  Evolver<2> evolver({&t, &image, field.get()}, classical_energies<2>());
  evolver.step(snake);
  for (auto _ : state) benchmark::DoNotOptimize(evolver.step(snake));
}
BENCHMARK(BM_EvolverStep2d)->ArgsProduct({{1000, 10000}, {1, 2}})->ArgNames({"vertices", "threads"})
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

// The basic edge-map field of §1 on the paper's lung volume size (230 x 300 x 80).
void BM_GradientField3dLungSize(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  Grid<3> g;
  g.size = {230, 300, 80};
  Image<3> img(g, 170.0f);
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    const Point<3> x = g.to_physical(g.index(l));
    if ((x - Point<3>(115, 150, 40)).cwiseQuotient(Point<3>(80, 110, 30)).norm() < 1) img[l] = 85.0f;
  }
  const auto spec = nlohmann::json::parse(R"({"type": "gradient", "sigma": 1.0})");
  JsonReader r(spec, "bench", "field");
  auto field = field_registry<3>().create(r);
  for (auto _ : state) field->compute(img);
}
BENCHMARK(BM_GradientField3dLungSize)->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond)
    ->UseRealTime()->Iterations(3);

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
