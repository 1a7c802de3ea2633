// The collision guard (framework/guard/collision_guard.h) on the snake iteration: two sheets of one
// closed surface pushed through each other cross without it and not with it; its counts are
// reported per phase; the same bits with 1 and 2 threads; no change at all when nothing collides;
// its kept broad-phase pairs give the same steps as a broad phase per iteration; the
// certificates of pairs that share one vertex are sound, and spare the exact tests of small moves.
#include "framework/core/evolver.h"
#include "framework/metrics/metrics.h"
#include "framework/guard/collision_guard.h"
#include "framework/geometry/triangle_pairs.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <random>

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
    // The counts of exact tests differ: a kept guard measures its certificates' drift from the
    // positions of its last build (or renewal), a fresh one from this step's (shared_vertex_radius).
    ASSERT_GT(a.checks, 0) << "step " << it;
    ASSERT_GT(b.checks, 0) << "step " << it;
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

// The certified pairs looked up by facet (only those of facets that drifted past their smallest
// certificate) are the ones filtering every kept pair finds due: the same positions
// and the same counts, exact tests included, at every step of the squeeze above, through
// renewals of the certificates and rebuilds.
TEST(CollisionGuard, CertificatesByFacetTestTheSamePairsAsFilteringAll) {
  Snake<3> s = pancake();
  CollisionGuard<3> indexed, every;
  every.set_certificate_index(false);
  int64_t checks = 0;
  for (int it = 0; it < 40; ++it) {
    SqueezeEnergy<3> squeeze(it % 7 == 6 ? 0.3 : (it % 3 == 0 ? 0.1 : 0.01));
    PointList<3> p(s.num_vertices());
    squeeze.propose(s, p);
    PointList<3> p_every = p;
    const MoveGuardReport a = indexed.guard(s, p), b = every.guard(s, p_every);
    ASSERT_EQ(p, p_every) << "step " << it;
    ASSERT_EQ(a.checks, b.checks) << "step " << it;
    ASSERT_EQ(a.shortened, b.shortened) << "step " << it;
    ASSERT_EQ(a.refused, b.refused) << "step " << it;
    checks += a.checks;
    s.positions() = p;
  }
  EXPECT_GT(checks, 0);
}

// shared_vertex_radius on a regular fan of six unit triangles around v = 0 (corners c_k at
// k x 60 degrees), by hand: for (v, c0, c1) and the opposite (v, c3, c4) the plane is the one
// whose normal points at 30 degrees, both heights are cos 30 = 0.8660, so r = 0.4330 - 0.05 =
// 0.3830; for (v, c0, c1) and (v, c2, c3) (one triangle between them) the normal is the x axis,
// the heights 0.5, so r = 0.25 - 0.05 = 0.2. Triangles sharing an edge or no vertex: none.
TEST(CollisionGuard, SharedVertexCertificateOnARegularFanIsAsComputedByHand) {
  auto corner = [](int k) {
    const double t = k * std::numbers::pi / 3;
    return Point<3>(std::cos(t), std::sin(t), 0.0);
  };
  const Point<3> v(0, 0, 0);
  const Triangle a{0, 1, 2};  // v = vertex 0, corner k = vertex k + 1
  const std::array<Point<3>, 3> pa{v, corner(0), corner(1)};
  EXPECT_NEAR(shared_vertex_radius(a, pa, Triangle{0, 4, 5}, {v, corner(3), corner(4)}), 0.5 * std::sqrt(3.0) / 2 - 0.05,
              1e-12);
  EXPECT_NEAR(shared_vertex_radius(a, pa, Triangle{0, 3, 4}, {v, corner(2), corner(3)}), 0.25 - 0.05, 1e-12);
  EXPECT_EQ(shared_vertex_radius(a, pa, Triangle{0, 2, 3}, {v, corner(1), corner(2)}), 0.0);  // an edge
  EXPECT_EQ(shared_vertex_radius(a, pa, Triangle{7, 8, 9}, {corner(3), corner(4), corner(5)}), 0.0);
}

// A certificate r of triangles ta and tb over the points x, put to the test: of 50 moves of every
// point by less than r (half to 0.999 r, half to 1 - 1e-9 of it), how many make pair_conflicts
// true (a sound certificate: none), and of 5 moves by up to 20 r, how many do (the check's teeth).
struct CertificateCheck {
  int conflicts_within = 0, conflicts_beyond = 0;
};
template <size_t N>
CertificateCheck check_certificate(std::mt19937& rng, const Triangle& ta, const Triangle& tb,
                                   const std::array<Point<3>, N>& x, double r) {
  std::uniform_real_distribution<double> unit(-1, 1);
  auto jitter = [&](double radius) {
    Point<3> d;
    do d = Point<3>(unit(rng), unit(rng), unit(rng));
    while (d.squaredNorm() > 1 || d.squaredNorm() < 1e-6);
    return Point<3>(d * radius);
  };
  auto conflicts_when_moved_by = [&](double radius) {
    std::array<Point<3>, N> y;
    for (size_t i = 0; i < N; ++i) y[i] = x[i] + jitter(radius);
    const std::array<Point<3>, 3> pa{y[ta[0]], y[ta[1]], y[ta[2]]}, pb{y[tb[0]], y[tb[1]], y[tb[2]]};
    const Point<3> loa = pa[0].cwiseMin(pa[1]).cwiseMin(pa[2]), hia = pa[0].cwiseMax(pa[1]).cwiseMax(pa[2]);
    const Point<3> lob = pb[0].cwiseMin(pb[1]).cwiseMin(pb[2]), hib = pb[0].cwiseMax(pb[1]).cwiseMax(pb[2]);
    return pair_conflicts(ta, pa, loa, hia, tb, pb, lob, hib);
  };
  CertificateCheck c;
  for (int k = 0; k < 50; ++k) c.conflicts_within += conflicts_when_moved_by(r * (k < 25 ? 0.999 : 1.0 - 1e-9));
  for (int k = 0; k < 5; ++k) c.conflicts_beyond += conflicts_when_moved_by(20 * r);
  return c;
}

// Soundness: for random pairs of triangles around a shared vertex (random directions and
// lengths, some nearly coplanar, some folded), every perturbation of the five vertices by less
// than the certificate leaves pair_conflicts false; perturbations twenty times larger do make
// conflicts, so the check has teeth.
TEST(CollisionGuard, SharedVertexCertificatesAreSound) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1), len(0.3, 2.0);
  auto direction = [&](double flat) {
    Point<3> d(unit(rng), unit(rng), flat * unit(rng));
    return Point<3>(d.normalized());
  };
  const Triangle ta{0, 1, 2}, tb{0, 3, 4};
  int certified = 0, tested = 0, beyond = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const double flat = trial % 4 == 0 ? 0.01 : 1.0;
    const Point<3> o(unit(rng) * 100, unit(rng) * 100, unit(rng) * 100);
    std::array<Point<3>, 5> x{o, o + len(rng) * direction(flat), o + len(rng) * direction(flat),
                              o + len(rng) * direction(flat), o + len(rng) * direction(flat)};
    const double r = shared_vertex_radius(ta, {x[0], x[1], x[2]}, tb, {x[0], x[3], x[4]});
    if (r <= 0) continue;
    ++certified;
    const CertificateCheck c = check_certificate(rng, ta, tb, x, r);
    ASSERT_EQ(c.conflicts_within, 0) << "trial " << trial;
    tested += 50;
    beyond += c.conflicts_beyond;
  }
  EXPECT_GT(certified, 500);
  EXPECT_EQ(tested, 50 * certified);
  EXPECT_GT(beyond, 10);  // moves far past the certificates do make conflicts
}

// shared_edge_radius by hand, on triangles with unit edge u-w = x and apexes at unit distance:
// for the flat pair (apexes +y and -y, opening 180 degrees) each turn may take half of 180 - 8 - 1
// degrees, s = sin 85.5 degrees, and r solves 4 r^2 + 2 S r = s |n| with S = 2, |n| = 1; for apexes
// +y and +z (90 degrees), s = sin 40.5 degrees; apexes 5 degrees apart fold (none), and pairs that
// share one vertex or none have none.
TEST(CollisionGuard, SharedEdgeCertificateIsAsComputedByHand) {
  const Point<3> u(0, 0, 0), w(1, 0, 0);
  const Triangle a{0, 1, 2}, b{1, 0, 3};
  const std::array<Point<3>, 3> pa{u, w, Point<3>(0, 1, 0)};
  auto expected = [](double degrees) {
    const double s = std::sin(degrees * std::numbers::pi / 180);
    return (std::sqrt(4 + 4 * s) - 2) / 4;
  };
  EXPECT_NEAR(shared_edge_radius(a, pa, b, {w, u, Point<3>(0, -1, 0)}), expected(85.5), 1e-12);
  EXPECT_NEAR(shared_edge_radius(a, pa, b, {w, u, Point<3>(0, 0, 1)}), expected(40.5), 1e-12);
  const double t = 5 * std::numbers::pi / 180;
  EXPECT_EQ(shared_edge_radius(a, pa, b, {w, u, Point<3>(0, std::cos(t), std::sin(t))}), 0.0);
  EXPECT_EQ(shared_edge_radius(a, pa, Triangle{0, 4, 5}, {u, Point<3>(-1, 0, 0), Point<3>(0, -1, 0)}), 0.0);
  EXPECT_EQ(shared_edge_radius(a, pa, Triangle{6, 4, 5}, {Point<3>(3, 0, 0), Point<3>(-1, 0, 0), Point<3>(0, -1, 0)}), 0.0);
}

// Soundness: for random pairs of triangles sharing an edge (either orientation; opening angles
// from folded to flat, some triangles thin), every perturbation of the four vertices by less
// than the certificate leaves pair_conflicts false; perturbations twenty times larger do make
// conflicts, so the check has teeth.
TEST(CollisionGuard, SharedEdgeCertificatesAreSound) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1), len(0.2, 2.0), angle(0, std::numbers::pi);
  int certified = 0, tested = 0, beyond = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const Triangle ta{0, 1, 2}, tb = trial % 2 ? Triangle{1, 0, 3} : Triangle{0, 1, 3};
    const Point<3> o(unit(rng) * 100, unit(rng) * 100, unit(rng) * 100);
    const Point<3> e = Point<3>(unit(rng), unit(rng), unit(rng)).normalized();
    const Point<3> n1 = e.unitOrthogonal(), n2 = e.cross(n1);
    // Apexes at heights h around the edge, at angles 0 and theta about it, offset along it.
    const double theta = trial % 5 == 0 ? 0.3 * angle(rng) : angle(rng), edge = len(rng);
    const double ha = trial % 7 == 0 ? 0.05 : len(rng), hb = len(rng);
    std::array<Point<3>, 4> x{o, o + edge * e, o + unit(rng) * edge * e + ha * n1,
                              o + unit(rng) * edge * e + hb * (std::cos(theta) * n1 + std::sin(theta) * n2)};
    const double r = shared_edge_radius(ta, {x[ta[0]], x[ta[1]], x[ta[2]]}, tb, {x[tb[0]], x[tb[1]], x[tb[2]]});
    if (r <= 0) continue;
    ++certified;
    const CertificateCheck c = check_certificate(rng, ta, tb, x, r);
    ASSERT_EQ(c.conflicts_within, 0) << "trial " << trial;
    tested += 50;
    beyond += c.conflicts_beyond;
  }
  EXPECT_GT(certified, 2000);
  EXPECT_EQ(tested, 50 * certified);
  EXPECT_GT(beyond, 10);  // moves far past the certificates do make conflicts
}

// With moves far smaller than the edges (a snake near convergence), the certified pairs are
// not tested: the exact tests of a step are fewer than the mesh's pairs of triangles that share
// one vertex, and the step is the one an unchecked iteration makes (nothing collides).
TEST(CollisionGuard, CertificatesSpareTheExactTestsOfSmallMoves) {
  Snake<3> s = test::icosphere(3, 10.0);
  const int nf = static_cast<int>(s.connectivity().triangles().size());
  CollisionGuard<3> guard;
  PointList<3> p(s.num_vertices());
  int64_t checks = 0;
  for (int it = 0; it < 5; ++it) {
    for (int v = 0; v < s.num_vertices(); ++v) p[v] = s.positions()[v] * (1 + 1e-4);
    const PointList<3> wanted = p;
    checks += guard.guard(s, p).checks;
    ASSERT_EQ(p, wanted);
    s.positions() = p;
  }
  // A closed mesh has 1.5 nf pairs of triangles sharing an edge and, around a vertex of valence
  // k, k (k - 3) / 2 sharing only it: about 4.5 nf on the icosphere (valence 6, V = nf / 2 + 2).
  // Without certificates each step would test all 6 nf; with them, not quite the 1.5 nf.
  EXPECT_LT(checks, 5 * 2 * nf);
  EXPECT_GT(checks, 0);
}

}  // namespace
}  // namespace dsnake
