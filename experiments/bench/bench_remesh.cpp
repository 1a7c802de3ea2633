// The remeshing stages of §5 and one pipeline pass, at about 1k, 7k and 30k vertices (the
// paper's lung ends near 7000), with 1 and 2 threads. BM_Pipeline* apply the stages one by one
// (as the evolver does today); BM_Pass* run the same stages through apply_pass (remesh/pass.h):
// one EditMesh for the whole pass, written back once, with the same result. The mesh is a torus (genus 1, so the
// planar method must cut it into discs) whose vertices are jittered along the surface
// (seeded), with every 4th vertex a deformation vertex: the state of a snake mid-evolution.
// Run: build/release/experiments/bench/bench_remesh --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include "framework/guard/collision_guard.h"
#include "remesh/delaunay.h"
#include "remesh/pass.h"
#include "remesh/quality.h"
#include "remesh/refine.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <numbers>
#include <random>

namespace dsnake {
namespace {

// Torus (R = 30, r = 10: physical units) with nu x nv vertices, nu = 2.5 nv, jittered by up to
// 0.3 of a grid step in each parameter direction.
Snake<3> bench_torus(int vertices) {
  const int nv = std::max(8, static_cast<int>(std::lround(std::sqrt(vertices / 2.5))));
  const int nu = std::max(8, vertices / nv);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  PointList<3> p;
  std::vector<int> ids;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * std::numbers::pi * (i + jitter(rng)) / nu, v = 2 * std::numbers::pi * (j + jitter(rng)) / nv;
      p.push_back({(30 + 10 * std::cos(v)) * std::cos(u), (30 + 10 * std::cos(v)) * std::sin(u), 10 * std::sin(v)});
      ids.push_back((i * nv + j) % 4 == 0 ? i * nv + j : -1);
    }
  auto id = [&](int i, int j) { return ((i + nu) % nu) * nv + (j + nv) % nv; };
  std::vector<Triangle> f;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      f.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      f.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  const int n = static_cast<int>(p.size());
  return Snake<3>(std::move(p), Connectivity::mesh(n, std::move(f)), std::move(ids));
}

// Mean edge length of the snake, for thresholds relative to its resolution.
double mean_edge(const Snake<3>& s) {
  double sum = 0;
  const auto edges = s.connectivity().edges();
  for (const auto& e : edges) sum += (s.positions()[e[0]] - s.positions()[e[1]]).norm();
  return sum / edges.size();
}

const Snake<3>& cached_torus(int vertices) {
  static std::map<int, Snake<3>> cache;
  auto it = cache.find(vertices);
  if (it == cache.end()) it = cache.emplace(vertices, bench_torus(vertices)).first;
  return it->second;
}

// The stages as a pipeline pass would configure them for this mesh: refine splits the
// triangles with an edge above 1.3 mean edges (about a tenth of them), simplify collapses
// below 0.5 mean edges.
std::vector<std::unique_ptr<Remesher<3>>> stages(const std::string& which, double edge) {
  std::vector<std::unique_ptr<Remesher<3>>> out;
  auto add = [&](const std::string& name) {
    if (name == "refine") out.push_back(std::make_unique<RefineRemesher>(RefineOptions{1.3 * edge, 0, 0.5}));
    if (name == "flips") out.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kFlips, 30, true, 25}));
    if (name == "flips_only") out.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kFlips, 30, false, 25}));
    if (name == "planar") out.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kPlanar, 30, false, 25}));
    if (name == "uniform") out.push_back(std::make_unique<UniformRemesher>(UniformOptions{1, 45}));
    if (name == "simplify") out.push_back(std::make_unique<SimplifyRemesher>(SimplifyOptions{0.5 * edge, edge, 0.1, 45}));
  };
  if (which.starts_with("pipeline") || which.starts_with("pass"))
    for (const char* s : {"refine", "flips", "uniform", "simplify"}) add(s);
  else
    add(which);
  return out;
}

// The torus after three pipeline passes: the steady state inside the evolution, where a pass
// finds little to do (thresholds from the jittered torus's mean edge, as in stages()).
const Snake<3>& cached_settled_torus(int vertices);

void run(benchmark::State& state, const std::string& which) {
  omp_set_num_threads(static_cast<int>(state.range(1)));
  const bool settled = which.ends_with("_settled");
  const bool pass = which.starts_with("pass");
  const Snake<3>& base = settled ? cached_settled_torus(static_cast<int>(state.range(0)))
                                 : cached_torus(static_cast<int>(state.range(0)));
  const double edge = mean_edge(cached_torus(static_cast<int>(state.range(0))));
  auto pipeline = stages(which, edge);
  Snake<3> s;
  for (auto _ : state) {
    state.PauseTiming();
    s = base;
    state.ResumeTiming();
    if (pass)
      apply_pass(pipeline, s, {});
    else
      for (auto& r : pipeline) r->apply(s, {});
  }
  const MeshQuality q = compute_mesh_quality(s);
  state.counters["vertices_in"] = base.num_vertices();
  state.counters["vertices_out"] = q.vertices;
  state.counters["valence6"] = q.valence6_share;
  state.counters["angle_ge20"] = q.share_min_angle_ge_20;
}

const Snake<3>& cached_settled_torus(int vertices) {
  static std::map<int, Snake<3>> cache;
  auto it = cache.find(vertices);
  if (it == cache.end()) {
    Snake<3> s = cached_torus(vertices);
    auto pipeline = stages("pipeline", mean_edge(s));
    for (int pass = 0; pass < 3; ++pass)
      for (auto& r : pipeline) r->apply(s, {});
    it = cache.emplace(vertices, std::move(s)).first;
  }
  return it->second;
}

// The collision guard (framework/guard/collision_guard.h) on one snake step of the 7000-vertex torus:
// every vertex moves across the surface (away from the tube's core circle) by 0.02 mean edges,
// outward for 10 steps, then inward for 10 (a snake near convergence). kept:1 keeps one guard
// across the steps, whose broad phase's pairs last while no vertex leaves its margin;
// kept:0 takes a new guard per step (a broad phase each time). broad_phases counts
// the broad phases run.
void BM_CollisionGuard(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(1)));
  const bool kept = state.range(0) != 0;
  Snake<3> s = cached_torus(7000);
  const double step = 0.02 * mean_edge(s);
  CollisionGuard<3> guard;
  PointList<3> p(s.num_vertices());
  int64_t t = 0, fresh_broad_phases = 0;
  for (auto _ : state) {
    const double sign = (t++ / 10) % 2 == 0 ? 1.0 : -1.0;
    for (int v = 0; v < s.num_vertices(); ++v) {
      const Point<3>& x = s.positions()[v];
      const Point<3> core = 30 * Point<3>(x.x(), x.y(), 0).normalized();
      p[v] = x + sign * step * (x - core).normalized();
    }
    if (kept) {
      guard.guard(s, p);
    } else {
      CollisionGuard<3> fresh;
      fresh.guard(s, p);
      fresh_broad_phases += fresh.broad_phases();
    }
    s.positions().swap(p);
  }
  state.counters["broad_phases"] = static_cast<double>(kept ? guard.broad_phases() : fresh_broad_phases);
}
BENCHMARK(BM_CollisionGuard)->ArgsProduct({{0, 1}, {1, 2}})->ArgNames({"kept", "threads"})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

#define DSNAKE_REMESH_BENCH(name, which)                                                     \
  void name(benchmark::State& state) { run(state, which); }                                 \
  BENCHMARK(name)->ArgsProduct({{1000, 7000, 30000}, {1, 2}})->ArgNames({"vertices", "threads"}) \
      ->Unit(benchmark::kMillisecond)->UseRealTime()

DSNAKE_REMESH_BENCH(BM_Refine, "refine");
DSNAKE_REMESH_BENCH(BM_DelaunayFlips, "flips_only");
DSNAKE_REMESH_BENCH(BM_DelaunayFlipsRegularize, "flips");
DSNAKE_REMESH_BENCH(BM_DelaunayPlanar, "planar");
DSNAKE_REMESH_BENCH(BM_Uniform, "uniform");
DSNAKE_REMESH_BENCH(BM_Simplify, "simplify");
DSNAKE_REMESH_BENCH(BM_Pipeline, "pipeline");
DSNAKE_REMESH_BENCH(BM_PipelineSettled, "pipeline_settled");
DSNAKE_REMESH_BENCH(BM_Pass, "pass");
DSNAKE_REMESH_BENCH(BM_PassSettled, "pass_settled");

}  // namespace
}  // namespace dsnake
BENCHMARK_MAIN();
