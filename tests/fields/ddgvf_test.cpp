// DDGVF: a vertex is blind to an edge whose gradient disagrees with its normal and attracted by
// one that agrees (two objects of opposite polarity); a ball attracts outward normals in 3D;
// the polarity option flips the roles; the field is thread-count independent and cacheable.
#include "fields/ddgvf.h"
#include "fields/edge_map.h"
#include "framework/numerics/grid_diffusion_solver.h"
#include "fields/registry.h"
#include "framework/core/errors.h"
#include "framework/core/force_strength.h"

#include <cmath>
#include <limits>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <omp.h>

namespace dsnake {
namespace {

// A 96 x 12 image constant along y: background 0.5, a bright band A (1) on x in [10, 25] and a
// dark band B (0) on x in [40, b_end]. With b_end = 55, B has a right edge at 55.5 whose
// gradient points along +x (dark to background); with b_end = 95 that edge does not exist.
Image<2> bands(int b_end) {
  Grid<2> grid;
  grid.size = GridIndex<2>(96, 12);
  Image<2> image(grid, 0.5f);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 96; ++x) {
      if (x >= 10 && x <= 25) image.at(GridIndex<2>(x, y)) = 1.0f;
      if (x >= 40 && x <= b_end) image.at(GridIndex<2>(x, y)) = 0.0f;
    }
  return image;
}

DdgvfFieldOptions options() {
  DdgvfFieldOptions o;
  o.edge.sigma = 1.0;
  o.solve.tolerance = 1e-6;  // both images have the same edge contrast, so the same f_max
  return o;
}

TEST(DdgvfField, DisagreeingNormalIsBlindToTheEdge) {
  DdgvfField<2> with_edge(options()), without_edge(options());
  with_edge.compute(bands(55));
  without_edge.compute(bands(95));
  const Point<2> plus(1, 0), minus(-1, 0);
  for (double x : {53.0, 54.5, 56.5, 58.0}) {
    const Point<2> p(x, 6);
    // Normal (-1, 0) disagrees with the +x gradient of B's right edge: the same force as
    // without that edge (to the solver tolerance).
    const Point<2> blind = with_edge.force(p, minus), reference = without_edge.force(p, minus);
    EXPECT_NEAR(blind.x(), reference.x(), 1e-4 * std::max(1e-3, std::abs(reference.x()))) << x;
    // Normal (+1, 0) agrees: the edge at 55.5 pulls the vertex onto it from both sides. Without
    // the edge, the same component points to -x everywhere here (to A's left edge at 9.5).
    const Point<2> felt = with_edge.force(p, plus), absent = without_edge.force(p, plus);
    EXPECT_LT(absent.x(), 0.0) << x;
    if (x < 55.5)
      EXPECT_GT(felt.x(), 0.1) << x;
    else
      EXPECT_LT(felt.x(), -0.1) << x;
  }
}

// The multigrid solves (which start from the masked source in place) and the explicit
// reference iteration (which keeps its own copy of the source) reach the same directional
// components, for both normals of each axis.
TEST(DdgvfField, MultigridReachesTheExplicitFixedPoint) {
  DdgvfFieldOptions o = options();
  o.solve.solver = GvfSolver::kExplicit;
  DdgvfField<2> ref(o);
  ref.compute(bands(55));
  o.solve.solver = GvfSolver::kMultigrid;
  DdgvfField<2> mg(o);
  mg.compute(bands(55));
  double scale = 0, diff = 0;
  for (int x = 0; x < 96; ++x)
    for (int y = 0; y < 12; y += 3)
      for (const Point<2>& n : {Point<2>(1, 1), Point<2>(-1, 1), Point<2>(1, -1), Point<2>(-1, -1)}) {
        const Point<2> p(x + 0.25, y + 0.5);
        scale = std::max(scale, ref.force(p, n).norm());
        diff = std::max(diff, (ref.force(p, n) - mg.force(p, n)).norm());
      }
  ASSERT_GT(scale, 0.1);
  EXPECT_LE(diff, 1e-3 * scale);
}

TEST(DdgvfField, EachComponentSeesOnlyItsPolarity) {
  DdgvfField<2> field(options());
  field.compute(bands(55));
  // Edges along +x (dark_inside agreeing with a +x normal): A's left (9.5) and B's right
  // (55.5); along -x: A's right (25.5) and B's left (39.5). On an edge of the other polarity a
  // component is smooth diffusion, not a sink: its value there is between its neighbours'.
  auto u = [&](int axis_sign, double x) { return field.component(0, axis_sign).sample(Point<2>(x, 6)); };
  // The + component pulls onto 55.5 from both sides; the - component does not change sign there.
  EXPECT_GT(u(0, 53.5), 0.0);
  EXPECT_LT(u(0, 57.5), 0.0);
  EXPECT_GT(u(1, 53.5) * u(1, 57.5), 0.0);
  // The - component pulls onto 39.5; the + component does not change sign there.
  EXPECT_GT(u(1, 37.5), 0.0);
  EXPECT_LT(u(1, 41.5), 0.0);
  EXPECT_GT(u(0, 37.5) * u(0, 41.5), 0.0);
  // No y force in a y-constant image.
  for (int s = 0; s < 2; ++s)
    for (double x = 0; x < 96; x += 1) EXPECT_NEAR(field.component(1, s).sample(Point<2>(x, 6)), 0.0, 1e-6);
}

// A ball of radius 8 (bright inside) in 33^3.
Image<3> ball() {
  Grid<3> grid;
  grid.size = GridIndex<3>(33, 33, 33);
  Image<3> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const double d = (grid.to_physical(grid.index(l)) - Point<3>(16, 16, 16)).norm();
    image[l] = float(1.0 / (1.0 + std::exp((d - 8.0) / 1.5)));
  }
  return image;
}

TEST(DdgvfField, BallAttractsOutwardNormalsWithMatchingPolarity) {
  DdgvfFieldOptions o;
  o.polarity = DdgvfPolarity::kBrightInside;
  DdgvfField<3> field(o);
  field.compute(ball());
  const Point<3> c(16, 16, 16);
  for (int k = 0; k < 27; ++k) {
    if (k == 13) continue;
    const Point<3> dir = Point<3>((k % 3) - 1, (k / 3 % 3) - 1, (k / 9) - 1).normalized();
    EXPECT_GT(field.force(c + 5.0 * dir, dir).dot(dir), 0.0) << k;
    EXPECT_LT(field.force(c + 12.0 * dir, dir).dot(dir), 0.0) << k;
  }
  // With the wrong polarity the surface is no sink for outward normals: along +x, the force
  // 2 mm inside and 2 mm outside the surface do not both point at it.
  DdgvfField<3> wrong;  // dark_inside
  wrong.compute(ball());
  const Point<3> dir(1, 0, 0);
  EXPECT_GT(field.force(c + 6.0 * dir, dir).x(), 0.0);
  EXPECT_LT(field.force(c + 10.0 * dir, dir).x(), 0.0);
  EXPECT_FALSE(wrong.force(c + 6.0 * dir, dir).x() > 0.0 && wrong.force(c + 10.0 * dir, dir).x() < 0.0);
}

TEST(DdgvfField, IndependentOfThreadCount) {
  const int threads = omp_get_max_threads();
  DdgvfFieldOptions o;
  o.solve.iterations = 2;  // 33^3 voxels: with 2 threads the six solves run two at a time (split solves: gvf tests)
  o.solve.tolerance = 0;
  DdgvfField<3> one(o), two(o);
  omp_set_num_threads(1);
  one.compute(ball());
  omp_set_num_threads(2);
  two.compute(ball());
  omp_set_num_threads(threads);
  for (int a = 0; a < 3; ++a)
    for (int s = 0; s < 2; ++s) ASSERT_EQ(one.component(a, s).data(), two.component(a, s).data());
}

// The prefetch hint (the voxels force() will read, chosen by the normal) is safe anywhere: before
// compute(), outside the grid, at a non-finite point; and changes no force.
TEST(DdgvfField, PrefetchIsSafeAnywhereAndChangesNothing) {
  DdgvfField<3> field;
  const Point<3> n(0.6, -0.8, 0.0);
  field.prefetch(Point<3>(1, 2, 3), n);  // before compute(): nothing to fetch
  field.compute(ball());
  const Point<3> x(10.3, 12.7, 15.2);
  const Point<3> before = field.force(x, n);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Point<3>& p : {x, Point<3>(-50, 1e6, 3), Point<3>(nan, 0, nan), Point<3>(0, 0, 0)})
    for (const Point<3>& normal : {n, Point<3>(-1, 1, -1), Point<3>(nan, nan, nan)}) field.prefetch(p, normal);
  EXPECT_EQ(field.force(x, n), before);
}

// The masks' signs (edge_map.h): I = x - 2 z has dI/dx = 1 > 0 (bit 0), dI/dy = 0 (bits 2 and 3
// clear) and dI/dz = -2 < 0 (bit 5) at every voxel, the border's one-sided differences included.
TEST(DdgvfField, MasksAreTheSignsOfTheImageGradient) {
  Grid<3> grid;
  grid.size = GridIndex<3>(8, 6, 5);
  Image<3> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const GridIndex<3> i = grid.index(l);
    image[l] = float(i.x() - 2 * i.z());
  }
  const EdgeMap<3> with = compute_edge_map(image, EdgeMapOptions{0.0, true}, true, "test");
  ASSERT_EQ(with.gradient_signs.size(), size_t(image.num_voxels()));
  for (uint8_t s : with.gradient_signs) ASSERT_EQ(s, 1 | 32);
  EXPECT_TRUE(compute_edge_map(image, EdgeMapOptions{0.0, true}, false, "test").gradient_signs.empty());
}

// vectors() is made on first use as the float sum of each axis's two components, and
// made anew after another compute(); the largest |F| the field tells without making them is the
// one max_force_magnitude reads off vectors().
TEST(DdgvfField, VectorsAreMadeOnDemandAsTheSumOfTheComponents) {
  DdgvfFieldOptions o;
  o.polarity = DdgvfPolarity::kBrightInside;
  o.edge.normalize = false;  // a dimmer image, weaker forces
  DdgvfField<3> field(o);
  Image<3> first = ball();
  field.compute(first);
  const double told = field.largest_vector_norm();
  for (int round = 0; round < 2; ++round) {
    const VectorField<3>& v = field.vectors();
    ASSERT_EQ(v.num_voxels(), field.num_voxels());
    double m2 = 0;
    for (int64_t l = 0; l < v.num_voxels(); ++l) {
      for (int a = 0; a < 3; ++a)
        ASSERT_EQ(v.at(l)[a], float(double(field.component(a, 0)[l]) + field.component(a, 1)[l])) << l;
      m2 = std::max(m2, v[l].squaredNorm());
    }
    EXPECT_EQ(field.largest_vector_norm(), std::sqrt(m2));
    EXPECT_GT(std::sqrt(m2), 0.0);
    // A dimmer ball on the same field: other components, so other vectors.
    for (float& x : first.data()) x *= 0.5f;
    field.compute(first);
  }
  EXPECT_NE(field.largest_vector_norm(), told);  // the components were made anew
  // max_force_magnitude takes the field's own figure; a field without one is read off vectors().
  EXPECT_EQ(max_force_magnitude(field), field.largest_vector_norm());
}

TEST(DdgvfField, RegistryReadsPolarity) {
  const nlohmann::json j = nlohmann::json::parse(R"({"type": "ddgvf", "mu": 0.1, "polarity": "bright_inside"})");
  JsonReader reader(j, "exp.json", "field");
  auto field = field_registry<3>().create(reader);
  auto* d = dynamic_cast<DdgvfField<3>*>(field.get());
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->options().polarity, DdgvfPolarity::kBrightInside);
  EXPECT_TRUE(d->uses_normal());
  const nlohmann::json bad = nlohmann::json::parse(R"({"type": "ddgvf", "polarity": "up"})");
  JsonReader r2(bad, "exp.json", "field");
  try {
    field_registry<3>().create(r2);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.polarity"), std::string::npos);
  }
}

}  // namespace
}  // namespace dsnake
