// The deformation energies: one 3D snake iteration at the paper's size (7000 vertices,
// approximate ASAP over 1 and 2 rings + internal + external sampling of a 230 x 300 x 80 field),
// 1000 2D iterations of a 400-vertex D-Snake, and exact against approximate ASAP (cost per
// iteration and the E_def reached after 50 ASAP-only iterations from a perturbed start).
// Run: build/release/experiments/bench/bench_energies --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include "energies/asap_mls.h"
#include "energies/patch.h"
#include "energies/registry.h"
#include "experiments/phantoms/phantoms.h"
#include "fields/gradient.h"
#include "framework/core/evolver.h"
#include "framework/core/image_filters.h"

#include <benchmark/benchmark.h>
#include <cmath>
#include <nlohmann/json.hpp>
#include <omp.h>
#include <random>

namespace dsnake {
namespace {

template <int D>
std::unique_ptr<Energy<D>> energy(const std::string& json) {
  const auto spec = nlohmann::json::parse(json);
  JsonReader r(spec, "bench", "energies");
  return energy_registry<D>().create(r);
}

// A torus of 100 x 70 = 7000 vertices (major radius 80, minor 25) about (115, 150, 40): inside
// the paper's 230 x 300 x 80 lung volume.
Template<3> torus_7000() {
  const int nu = 100, nv = 70;
  Template<3> t;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      t.positions.emplace_back(115 + (80 + 25 * std::cos(v)) * std::cos(u), 150 + (80 + 25 * std::cos(v)) * std::sin(u),
                               40 + 25 * std::sin(v));
    }
  std::vector<Triangle> tris;
  auto id = [&](int i, int j) { return ((i + nu) % nu) * nv + (j + nv) % nv; };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      tris.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      tris.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  t.connectivity = Connectivity::mesh(nu * nv, tris);
  return t;
}

// A lung-sized volume (230 x 300 x 80 voxels of 1 mm, 170 outside) holding a solid torus about
// the z axis through (115, 150, 40), of major radius `major` and minor radius `minor` (mm), its
// voxels set to inside(x).
template <class Inside>
Image<3> torus_volume(double major, double minor, Inside inside) {
  Grid<3> g;
  g.size = {230, 300, 80};
  Image<3> img(g, 170.0f);
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    const Point<3> x = g.to_physical(g.index(l));
    const double rho = std::hypot(x[0] - 115, x[1] - 150) - major;
    if (std::hypot(rho, x[2] - 40) < minor) img[l] = inside(x);
  }
  return img;
}

const GradientField<3>& lung_size_field() {
  static const GradientField<3> field = [] {
    const Image<3> img = torus_volume(85, 22, [](const Point<3>&) { return 85.0f; });
    GradientField<3> f;
    f.compute(img);
    return f;
  }();
  return field;
}

// Times energy.propose() on the template itself (the snake at the template's positions);
// returns that snake, for the counters.
Snake<3> time_proposals(benchmark::State& state, Energy<3>& energy, const Template<3>& t) {
  Snake<3> snake = Snake<3>::from_template(t, t.positions);
  energy.bind({&t}, snake);
  PointList<3> out(snake.num_vertices());
  for (auto _ : state) {
    energy.propose(snake, out);
    benchmark::DoNotOptimize(out.data());
  }
  return snake;
}

// One D-Snake iteration, 3D, 7000 vertices: internal (alpha 0.1, beta 0) + external + approximate
// ASAP (Jacobi order: parallel) over `rings` rings, averaged by the Evolver (energy trace off).
void BM_DsnakeStep3d(benchmark::State& state) {
  omp_set_num_threads(int(state.range(1)));
  static const Template<3> t = torus_7000();
  const auto& field = lung_size_field();
  std::vector<WeightedEnergy<3>> energies;
  energies.push_back({1.0, energy<3>(R"({"type": "internal", "alpha": 0.1, "beta": 0.0})")});
  energies.push_back({1.0, energy<3>(R"({"type": "external", "tau": 1.0})")});
  energies.push_back({1.0, energy<3>(R"({"type": "asap_mls", "variant": "approximate", "iteration": "jacobi", "neighborhood": "rings", "rings": )" +
                                     std::to_string(state.range(0)) + "}")});
  Evolver<3> evolver({&t, nullptr, &field}, std::move(energies));
  evolver.set_trace_energy(false);
  Snake<3> snake = Snake<3>::from_template(t, t.positions);
  evolver.step(snake);  // binds once
  for (auto _ : state) benchmark::DoNotOptimize(evolver.step(snake));
  state.counters["vertices"] = snake.num_vertices();
}
BENCHMARK(BM_DsnakeStep3d)->ArgsProduct({{1, 2}, {1, 2}})->ArgNames({"rings", "threads"})
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

// The approximate ASAP proposal alone on the same mesh; order 0: Jacobi (parallel), 1: Gauss-Seidel.
void BM_AsapApproximate3d(benchmark::State& state) {
  omp_set_num_threads(int(state.range(1)));
  static const Template<3> t = torus_7000();
  const std::string order = state.range(2) == 0 ? "jacobi" : "gauss_seidel";
  auto e = energy<3>(R"({"type": "asap_mls", "variant": "approximate", "neighborhood": "rings", "rings": )" +
                     std::to_string(state.range(0)) + R"(, "iteration": ")" + order + "\"}");
  const Snake<3> snake = time_proposals(state, *e, t);
}
BENCHMARK(BM_AsapApproximate3d)->ArgsProduct({{1, 2}, {1, 2}, {0, 1}})->ArgNames({"rings", "threads", "gauss_seidel"})
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

// The other two terms of the 3D iteration alone: the internal step (alpha 0.1, beta 0 or 0.01) and
// the external field sampling, on the same mesh.
void BM_InternalAndExternal3d(benchmark::State& state) {
  omp_set_num_threads(int(state.range(1)));
  static const Template<3> t = torus_7000();
  const auto& field = lung_size_field();
  const char* json[] = {R"({"type": "internal", "alpha": 0.1, "beta": 0.0})", R"({"type": "internal", "alpha": 0.1, "beta": 0.01})",
                        R"({"type": "external", "tau": 1.0})"};
  auto e = energy<3>(json[state.range(0)]);
  Snake<3> snake = Snake<3>::from_template(t, t.positions);
  e->bind({&t, nullptr, &field}, snake);
  PointList<3> out(snake.num_vertices());
  for (auto _ : state) {
    e->propose(snake, out);
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_InternalAndExternal3d)->ArgsProduct({{0, 1, 2}, {1, 2}})->ArgNames({"term", "threads"})
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

// The internal step alone, "umbrella" (0) against "physical" (1: M and K refreshed and the system
// refactorised every step), alpha 0.5, beta 0 or 0.01, on the 2562-vertex icosphere (radius 50)
// and the 7000-vertex torus.
void BM_InternalDiscretization3d(benchmark::State& state) {
  omp_set_num_threads(int(state.range(3)));
  static const Template<3> sphere = [] {
    Template<3> t = make_icosphere(4);
    for (auto& p : t.positions) p *= 50.0;
    return t;
  }();
  static const Template<3> torus = torus_7000();
  const Template<3>& t = state.range(0) == 0 ? sphere : torus;
  const std::string json = std::string(R"({"type": "internal", "alpha": 0.5, "beta": )") + (state.range(2) == 0 ? "0.0" : "0.01") +
                           R"(, "discretization": ")" + (state.range(1) == 0 ? "umbrella" : "physical") + "\"}";
  auto e = energy<3>(json);
  const Snake<3> snake = time_proposals(state, *e, t);
  state.counters["vertices"] = snake.num_vertices();
}
BENCHMARK(BM_InternalDiscretization3d)->ArgsProduct({{0, 1}, {0, 1}, {0, 1}, {1, 2}})
    ->ArgNames({"torus", "physical", "beta", "threads"})->Unit(benchmark::kMicrosecond)->UseRealTime();

// 2D: 1000 iterations of a 400-vertex D-Snake (internal + external + ASAP) on a precomputed
// field; 0: exact Gauss-Seidel, 1: approximate Gauss-Seidel; 2-ring neighbourhoods.
void BM_Dsnake2d1000Iterations(benchmark::State& state) {
  omp_set_num_threads(int(state.range(1)));
  static const GradientField<2> field = [] {
    Grid<2> g;
    g.size = {512, 512};
    Image<2> img(g, 170.0f);
    for (int64_t l = 0; l < g.num_voxels(); ++l)
      if ((g.to_physical(g.index(l)) - Point<2>(255.5, 255.5)).norm() < 150) img[l] = 85.0f;
    GradientField<2> f;
    f.compute(img);
    return f;
  }();
  const int n = 400;
  Template<2> t;
  for (int k = 0; k < n; ++k)
    t.positions.emplace_back(255.5 + 180 * std::cos(2 * M_PI * k / n), 255.5 + 180 * std::sin(2 * M_PI * k / n));
  t.connectivity = Connectivity::polygon(n);
  const std::string variant = state.range(0) == 0 ? "exact" : "approximate";
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<WeightedEnergy<2>> energies;
    energies.push_back({1.0, energy<2>(R"({"type": "internal", "alpha": 0.1, "beta": 0.01})")});
    energies.push_back({1.0, energy<2>(R"({"type": "external", "tau": 1.0})")});
    energies.push_back({1.0, energy<2>(R"({"type": "asap_mls", "neighborhood": "rings", "rings": 2, "variant": ")" + variant + "\"}")});
    Evolver<2> evolver({&t, nullptr, &field}, std::move(energies));
    evolver.set_trace_energy(false);
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    state.ResumeTiming();
    for (int it = 0; it < 1000; ++it) benchmark::DoNotOptimize(evolver.step(snake));
  }
}
BENCHMARK(BM_Dsnake2d1000Iterations)->ArgsProduct({{0, 1}, {1, 2}})->ArgNames({"approximate", "threads"})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

// Exact against approximate: time of one ASAP-only proposal, and E_def after 50 of them from the
// template plus uniform noise (counter e_def_ratio = E_def(50) / E_def(0)).
template <int D>
void asap_quality(benchmark::State& state, const Template<D>& t, const std::string& json) {
  omp_set_num_threads(1);
  auto e = energy<D>(json);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1, 1);
  PointList<D> start = t.positions;
  for (auto& x : start)
    for (int a = 0; a < D; ++a) x[a] += u(rng);
  Snake<D> snake = Snake<D>::from_template(t, start);
  e->bind({&t}, snake);
  const double first = e->value(snake);
  PointList<D> out(snake.num_vertices());
  for (int it = 0; it < 50; ++it) {
    e->propose(snake, out);
    snake.positions() = out;
  }
  state.counters["e_def_ratio"] = e->value(snake) / first;
  for (auto _ : state) {
    e->propose(snake, out);
    benchmark::DoNotOptimize(out.data());
  }
}

std::string asap_json(int variant, int rings) {
  const char* v[] = {R"("variant": "exact", "iteration": "gauss_seidel")", R"("variant": "exact", "iteration": "jacobi")",
                     R"("variant": "approximate", "iteration": "gauss_seidel")", R"("variant": "approximate", "iteration": "jacobi")"};
  return std::string(R"({"type": "asap_mls", "neighborhood": "rings", "rings": )") + std::to_string(rings) + ", " + v[variant] + "}";
}

// 2D, 400-vertex jittered circle (radius 100), rings in {1, 2, 4, 8};
// variant 0 exact Gauss-Seidel, 1 exact Jacobi, 2 approximate Gauss-Seidel, 3 approximate Jacobi.
void BM_AsapQuality2d(benchmark::State& state) {
  static const Template<2> t = [] {
    Template<2> t;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.9, 1.1);
    for (int k = 0; k < 400; ++k)
      t.positions.emplace_back(100 * u(rng) * std::cos(2 * M_PI * k / 400), 100 * u(rng) * std::sin(2 * M_PI * k / 400));
    t.connectivity = Connectivity::polygon(400);
    return t;
  }();
  asap_quality<2>(state, t, asap_json(int(state.range(0)), int(state.range(1))));
}
BENCHMARK(BM_AsapQuality2d)->ArgsProduct({{0, 1, 2, 3}, {1, 2, 4, 8}})->ArgNames({"variant", "rings"})
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

// 3D, 2562-vertex icosphere of radius 50; variant 1 exact (alternating, §4.2), 2 approximate
// Gauss-Seidel, 3 approximate Jacobi.
void BM_AsapQuality3d(benchmark::State& state) {
  static const Template<3> t = [] {
    Template<3> t = make_icosphere(4);
    for (auto& p : t.positions) p *= 50;
    return t;
  }();
  asap_quality<3>(state, t, asap_json(int(state.range(0)), int(state.range(1))));
}
BENCHMARK(BM_AsapQuality3d)->ArgsProduct({{1, 2, 3}, {1, 2, 3}})->ArgNames({"variant", "rings"})
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

// The patch force on the 7000-vertex torus in the lung-sized volume (the torus' own image as the
// atlas, the snake moved 0.7 mm off it): one propose() (a Gauss-Newton step per vertex, patches of
// +-`radius` mm on the 1 mm grid; with map_radius 6, each vertex's local affine map refitted
// first, over its neighbours within 6 mm: the map_radius 0 row is the single placement map).
void BM_PatchPropose3d(benchmark::State& state) {
  static const Image<3> image =
      gaussian_blur(torus_volume(80, 25, [](const Point<3>& x) { return 85.0f + 30.0f * (x[0] > 115); }), 1.0);
  omp_set_num_threads(static_cast<int>(state.range(1)));
  const Template<3> t = torus_7000();
  PatchOptions o;
  o.radius = static_cast<double>(state.range(0));
  o.map_radius = static_cast<double>(state.range(2));
  PatchEnergy<3> patch(o);
  PointList<3> moved = t.positions;
  for (auto& p : moved) p += Point<3>(0.7, 0.0, 0.0);
  Snake<3> snake = Snake<3>::from_template(t, moved);
  EnergyContext<3> context{&t, &image};
  context.reference_image = &image;
  patch.bind(context, snake);
  PointList<3> out(snake.num_vertices());
  patch.propose(snake, out);
  for (auto _ : state) {
    patch.propose(snake, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["vertices"] = snake.num_vertices();
}
BENCHMARK(BM_PatchPropose3d)
    ->ArgsProduct({{3, 4}, {1, 2}, {0, 6}})
    ->ArgNames({"radius", "threads", "map_radius"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
