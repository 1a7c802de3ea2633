// The collision guard (remesh/collision_guard.h) on the snake iteration: two sheets of one
// closed surface pushed through each other cross without it and not with it; its counts are
// reported per phase; the same bits with 1 and 2 threads; no change at all when nothing collides;
// its kept broad-phase pairs give the same steps as a broad phase per iteration.
#include "framework/core/evolver.h"
#include "framework/metrics/metrics.h"
#include "remesh/collision_guard.h"
#include "tests/remesh/test_meshes.h"

#include <gtest/gtest.h>
#include <omp.h>

namespace dsnake {
namespace {

// Pushes every vertex above the plane y = 0 (2D) / z = 0 (3D) down by `step` and every vertex
// below it up: the two sheets of a flat closed surface are driven through each other.
template <int D>
class SqueezeEnergy final : public Energy<D> {
 public:
  explicit SqueezeEnergy(double step) : step_(step) {}
  std::string type() const override { return "squeeze"; }
  void bind(const EnergyContext<D>&, const Snake<D>&) override {}
  void propose(const Snake<D>& snake, PointList<D>& out) override {
    for (int v = 0; v < snake.num_vertices(); ++v) {
      const Point<D>& x = snake.positions()[v];
      out[v] = x;
      if (std::abs(x[D - 1]) > 1e-9) out[v][D - 1] -= std::copysign(step_, x[D - 1]);
    }
  }
  double value(const Snake<D>&) const override { return 0; }

 private:
  double step_;
};

// Moves every vertex a tenth of the way to the origin: the surface shrinks, nothing collides.
class ShrinkEnergy final : public Energy<3> {
 public:
  std::string type() const override { return "shrink"; }
  void bind(const EnergyContext<3>&, const Snake<3>&) override {}
  void propose(const Snake<3>& snake, PointList<3>& out) override {
    for (int v = 0; v < snake.num_vertices(); ++v) out[v] = 0.9 * snake.positions()[v];
  }
  double value(const Snake<3>&) const override { return 0; }
};

// A flat closed surface: an icosphere of radius 10 squashed to half-height 1 (3D), or an
// ellipse 10 x 1 (2D), its two sheets 2 apart.
Snake<3> pancake() {
  Snake<3> s = test::icosphere(3, 10.0);
  PointList<3> q = s.positions();
  for (auto& x : q) x.z() *= 0.1;
  s.set_topology(std::move(q), s.connectivity(), s.template_ids());
  return s;
}
Snake<2> flat_ellipse() {
  PointList<2> q;
  for (int k = 0; k < 200; ++k) {
    const double t = 2 * std::numbers::pi * (k + 0.5) / 200;
    q.push_back({10 * std::cos(t), std::sin(t)});
  }
  std::vector<int> ids(200);
  for (int k = 0; k < 200; ++k) ids[k] = k;
  return Snake<2>(std::move(q), Connectivity::polygon(200), std::move(ids));
}

template <int D>
struct SqueezeResult {
  Snake<D> snake;
  MoveGuardReport report;
  int self_intersections;
};

template <int D>
SqueezeResult<D> squeeze(Snake<D> s, bool guard, int iterations = 12, bool shrink = false) {
  std::vector<WeightedEnergy<D>> e;
  if constexpr (D == 3)
    if (shrink) e.push_back({1.0, std::make_unique<ShrinkEnergy>()});
  if (e.empty()) e.push_back({1.0, std::make_unique<SqueezeEnergy<D>>(0.25)});
  Evolver<D> evolver({}, std::move(e));
  if (guard) evolver.set_move_guard(std::make_unique<CollisionGuard<D>>());
  std::vector<Phase<D>> phases(1);
  phases[0].iterations = iterations;
  const EvolveSummary summary = evolver.run(s, phases);
  const int crossings = count_self_intersections<D>({s.positions(), s.connectivity()});
  return {std::move(s), summary.phases[0].move_guard, crossings};
}

TEST(CollisionGuard, SheetsPushedThroughEachOtherCrossOnlyWithoutIt3D) {
  const auto without = squeeze<3>(pancake(), false);
  EXPECT_GT(without.self_intersections, 0);
  const auto with = squeeze<3>(pancake(), true);
  EXPECT_EQ(with.self_intersections, 0);
  EXPECT_GT(with.report.shortened + with.report.refused, 0);
  EXPECT_GT(with.report.checks, 0);
  // The sheets came close: the guard stops them at contact, not where they started.
  double gap = 1e9;
  for (const auto& x : with.snake.positions())
    if (std::hypot(x.x(), x.y()) < 5) gap = std::min(gap, std::abs(x.z()));
  EXPECT_LT(gap, 0.25);
}

TEST(CollisionGuard, SegmentsPushedThroughEachOtherCrossOnlyWithoutIt2D) {
  const auto without = squeeze<2>(flat_ellipse(), false);
  EXPECT_GT(without.self_intersections, 0);
  const auto with = squeeze<2>(flat_ellipse(), true);
  EXPECT_EQ(with.self_intersections, 0);
  EXPECT_GT(with.report.shortened + with.report.refused, 0);
}

TEST(CollisionGuard, SameBitsWithOneAndTwoThreads) {
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const auto one = squeeze<3>(pancake(), true);
  omp_set_num_threads(2);
  const auto two = squeeze<3>(pancake(), true);
  omp_set_num_threads(threads);
  EXPECT_EQ(one.snake.positions(), two.snake.positions());
  EXPECT_EQ(one.report.shortened, two.report.shortened);
  EXPECT_EQ(one.report.refused, two.report.refused);
  EXPECT_EQ(one.report.checks, two.report.checks);
}

TEST(CollisionGuard, ChangesNothingWhenNothingCollides) {
  const auto without = squeeze<3>(pancake(), false, 5, true);
  const auto with = squeeze<3>(pancake(), true, 5, true);
  EXPECT_EQ(with.snake.positions(), without.snake.positions());
  EXPECT_EQ(with.report.shortened + with.report.refused, 0);
  EXPECT_GT(with.report.checks, 0);
}

// The guard keeps its broad phase's pairs across iterations while no vertex leaves its margin
// (a Verlet list): a guard kept over 40 squeeze steps (small ones and some long ones), through
// the sheets' contact, gives
// the same positions and counts at every step as a new guard per step (a broad phase each
// time), with fewer broad phases than steps but more than one.
template <int D>
void expect_kept_pairs_match_fresh(Snake<D> s) {
  CollisionGuard<D> kept;
  MoveGuardReport total;
  const int steps = 40;
  for (int it = 0; it < steps; ++it) {
    // Small steps, and every seventh a long one (beyond any margin: a rebuild on a long move).
    SqueezeEnergy<D> squeeze(it % 7 == 6 ? 0.3 : 0.04);
    PointList<D> p(s.num_vertices());
    squeeze.propose(s, p);
    PointList<D> p_fresh = p;
    CollisionGuard<D> fresh;
    const MoveGuardReport a = kept.guard(s, p), b = fresh.guard(s, p_fresh);
    ASSERT_EQ(p, p_fresh) << "step " << it;
    ASSERT_EQ(a.checks, b.checks) << "step " << it;
    ASSERT_EQ(a.shortened, b.shortened) << "step " << it;
    ASSERT_EQ(a.refused, b.refused) << "step " << it;
    total += a;
    s.positions() = p;
  }
  EXPECT_GT(total.shortened + total.refused, 0);  // the sheets met
  EXPECT_LT(kept.broad_phases(), steps);
  EXPECT_GT(kept.broad_phases(), 1);
  EXPECT_EQ(count_self_intersections<D>({s.positions(), s.connectivity()}), 0);
}

TEST(CollisionGuard, KeptPairsGiveTheSameStepsAsABroadPhasePerIteration) {
  expect_kept_pairs_match_fresh<3>(pancake());
  expect_kept_pairs_match_fresh<2>(flat_ellipse());
}

}  // namespace
}  // namespace dsnake
