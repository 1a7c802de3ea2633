// A mesh that stays clean through the evolution: the four §5 stages run every 10
// iterations while the snake moves onto a hidden surface (an ellipsoid, a torus, a genus-2
// surface) and refines about ten-fold; the final mesh must be free of self-intersections and
// almost regular. And the collision guard (framework/guard/collision_guard.h) on the snake iteration.
#include "energies/internal.h"
#include "framework/core/evolver.h"
#include "framework/metrics/metrics.h"
#include "framework/guard/collision_guard.h"
#include "remesh/delaunay.h"
#include "remesh/pipeline.h"
#include "remesh/quality.h"
#include "remesh/refine.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cstdio>
#include <functional>

namespace dsnake {
namespace {

// The image force of a hidden implicit surface f = 0: each vertex a share `step` of its Newton
// step towards the surface (what a distance-based external field does, without an image).
class ImplicitAttraction final : public Energy<3> {
 public:
  ImplicitAttraction(std::function<double(const Point<3>&)> f, double step) : f_(std::move(f)), step_(step) {}
  std::string type() const override { return "implicit_attraction"; }
  void bind(const EnergyContext<3>&, const Snake<3>&) override {}
  void propose(const Snake<3>& snake, PointList<3>& out) override {
    const auto& q = snake.positions();
#pragma omp parallel for schedule(static)
    for (int v = 0; v < snake.num_vertices(); ++v) out[v] = q[v] + step_ * (test::towards_surface(f_, q[v]) - q[v]);
  }
  double value(const Snake<3>& snake) const override {
    double e = 0;
    for (const auto& x : snake.positions()) e += f_(x) * f_(x);
    return e;
  }

 private:
  std::function<double(const Point<3>&)> f_;
  double step_;
};

struct InLoopRun {
  Snake<3> start;
  std::function<double(const Point<3>&)> surface;
  double max_edge, start_max_edge;
  int iterations = 150, every = 10;
  bool guard = true;
  bool relax = true;  // simplify's closing relaxation sweep (its default)
};

struct InLoopResult {
  Snake<3> snake;
  MeshQuality quality;
  int self_intersections = 0;
  MoveGuardReport guard;
};

std::vector<std::unique_ptr<Remesher<3>>> four_stages(double max_edge, double start_max_edge, bool relax) {
  std::vector<std::unique_ptr<Remesher<3>>> stages;
  stages.push_back(std::make_unique<RefineRemesher>(RefineOptions{max_edge, start_max_edge, 0.5}));
  stages.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{}));
  stages.push_back(std::make_unique<UniformRemesher>(UniformOptions{}));
  SimplifyOptions simplify;
  simplify.relax = relax;
  stages.push_back(std::make_unique<SimplifyRemesher>(simplify));
  return stages;
}

InLoopResult run_in_loop(const InLoopRun& run) {
  InLoopResult r{run.start, {}, 0, {}};
  Template<3> tmpl{run.start.positions(), run.start.connectivity(), {}};
  std::vector<WeightedEnergy<3>> energies;
  energies.push_back({1.0, std::make_unique<InternalEnergy<3>>(InternalOptions{0.1, 0.0, 1.0})});
  energies.push_back({1.0, std::make_unique<ImplicitAttraction>(run.surface, 0.5)});
  EnergyContext<3> context;
  context.tmpl = &tmpl;
  Evolver<3> evolver(context, std::move(energies));
  if (run.guard) evolver.set_move_guard(std::make_unique<CollisionGuard<3>>());
  std::vector<Phase<3>> phases(1);
  phases[0].iterations = run.iterations;
  phases[0].every = run.every;
  phases[0].remesher = std::make_unique<RemeshPipeline<3>>(four_stages(run.max_edge, run.start_max_edge, run.relax));
  const double t0 = omp_get_wtime();
  const EvolveSummary summary = evolver.run(r.snake, phases);
  const double seconds = omp_get_wtime() - t0;
  EXPECT_NE(summary.status, EvolveStatus::kDiverged);
  r.guard = summary.phases[0].move_guard;
  r.quality = compute_mesh_quality(r.snake);
  r.self_intersections = count_self_intersections<3>({r.snake.positions(), r.snake.connectivity()});
  std::printf("  %.2f s, %d -> %d vertices: valence 6 %.1f%%, min angle >= 20: %.1f%%, min angle %.2f deg, %d self-intersections,"
              " guard shortened %lld refused %lld checks %lld\n",
              seconds, run.start.num_vertices(), r.quality.vertices, 100 * r.quality.valence6_share,
              100 * r.quality.share_min_angle_ge_20, r.quality.min_angle_deg, r.self_intersections,
              static_cast<long long>(r.guard.shortened), static_cast<long long>(r.guard.refused),
              static_cast<long long>(r.guard.checks));
  return r;
}

// The stages must keep >= 85% valence-6 vertices on every shape. With the physical internal
// energy (cotangent, no tangential motion; the default) they reach ellipsoid 87.0%, torus 87.5%,
// genus 2 89.2% (min angle >= 20: 100% on all three; smallest angles 29.2, 30.1, 30.4 degrees;
// 1566, 4553, 2379 vertices), helped by the defect moves of the valence flips
// (remesh/delaunay.cpp: a flip that keeps the valences' deviation, kept when one or two more then
// lower it) and simplify's closing relaxation sweep. The shares depend on the order in which the
// searches and sweeps meet triangles and corners by about a point: with best_second_flip's ties
// going to the last candidate instead of the first, 87.6%, 87.8%, 88.8%. `valence6` is asserted
// with a small margin.
void expect_clean(const InLoopResult& r, int chi, int start_vertices, double valence6) {
  EXPECT_EQ(r.quality.euler_characteristic, chi);
  EXPECT_TRUE(r.quality.closed);
  EXPECT_EQ(r.self_intersections, 0);
  EXPECT_GE(r.quality.valence6_share, valence6);
  EXPECT_GE(r.quality.share_min_angle_ge_20, 0.95);
  EXPECT_GE(r.quality.vertices, 7 * start_vertices);  // refined about ten-fold
}

TEST(CleanMesh, EllipsoidInsideTheEvolution) {
  auto f = [](const Point<3>& x) { return (x.cwiseQuotient(Point<3>(24, 18, 14)).norm() - 1) * 14; };
  const InLoopResult r = run_in_loop({test::icosphere(2, 27.0), f, 2.5, 5.0});
  expect_clean(r, 2, 162, 0.865);
}

// The same without simplify's closing relaxation sweep: 88.2% (1942 vertices).
TEST(CleanMesh, UnrelaxedEllipsoidInsideTheEvolution) {
  auto f = [](const Point<3>& x) { return (x.cwiseQuotient(Point<3>(24, 18, 14)).norm() - 1) * 14; };
  InLoopRun run{test::icosphere(2, 27.0), f, 2.5, 5.0};
  run.relax = false;
  const InLoopResult r = run_in_loop(run);
  expect_clean(r, 2, 162, 0.855);
}

TEST(CleanMesh, TorusInsideTheEvolution) {
  auto f = [](const Point<3>& x) { return test::torus_sdf(x, 30, 10); };
  const InLoopResult r = run_in_loop({test::torus(24, 15, 30, 6), f, 2.5, 6.0});
  expect_clean(r, 0, 360, 0.865);
}

TEST(CleanMesh, Genus2InsideTheEvolution) {
  auto f = [](const Point<3>& x) { return test::genus2_sdf(x); };
  const Snake<3> start = test::genus2_template(2);
  const InLoopResult r = run_in_loop({start, f, 2.0, 5.0});
  expect_clean(r, -2, start.num_vertices(), 0.88);
}

}  // namespace
}  // namespace dsnake
