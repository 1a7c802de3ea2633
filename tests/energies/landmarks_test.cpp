// The landmark energy (energies/landmarks.h): its proposal, value, residuals and
// distances against hand-computed numbers, the vertices it governs (landmark vertices only,
// found through their template ids after free vertices were inserted), the world-to-frame map
// of its points on an oblique image, the averaged update of §3.1 (landmark vertices move to the
// weighted mean with their point, every other vertex exactly as without the springs), and the
// one-line errors naming the JSON path.
#include "energies/landmarks.h"

#include "framework/core/errors.h"
#include "framework/core/evolver.h"
#include "framework/core/image.h"
#include "framework/global/global_problem.h"
#include "tests/energy_fixtures.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>

namespace dsnake {
namespace {

// The unit square with landmarks "a" (vertex 0) and "c" (vertex 2).
Template<2> square() {
  Template<2> t;
  t.positions = {Point<2>(0, 0), Point<2>(1, 0), Point<2>(1, 1), Point<2>(0, 1)};
  t.connectivity = Connectivity::polygon(4);
  t.landmarks = {{"a", 0}, {"c", 2}};
  return t;
}

const char* kSprings = R"({"type": "landmarks", "points": {"a": [1, 2], "c": [5, 5]}})";

TEST(LandmarksEnergy, ProposalValueResidualsAndDistancesHandComputed) {
  const Template<2> t = square();
  auto e = test_support::make_energy<2>(kSprings);
  e->check_template(t);
  PointList<2> q = {Point<2>(-1, 0), Point<2>(1, 0), Point<2>(2, 2), Point<2>(0, 1)};
  Snake<2> snake = Snake<2>::from_template(t, q);
  e->bind({&t}, snake);
  EXPECT_EQ(e->governs(), Governs::kMarkedVertices);
  const auto mask = e->governed_mask();
  EXPECT_EQ(std::vector<uint8_t>(mask.begin(), mask.end()), (std::vector<uint8_t>{1, 0, 1, 0}));
  PointList<2> out(4, Point<2>::Constant(NAN));
  e->propose(snake, out);
  EXPECT_EQ(out[0], Point<2>(1, 2));
  EXPECT_EQ(out[2], Point<2>(5, 5));
  EXPECT_TRUE(std::isnan(out[1].x()) && std::isnan(out[3].x()));  // not governed: left as they were
  // |(-1, 0) - (1, 2)|^2 + |(2, 2) - (5, 5)|^2 = 8 + 18
  EXPECT_DOUBLE_EQ(e->value(snake), 26.0);
  const auto d = static_cast<const LandmarksEnergy<2>&>(*e).distances(snake);
  EXPECT_DOUBLE_EQ(d.at("a"), std::sqrt(8.0));
  EXPECT_DOUBLE_EQ(d.at("c"), std::sqrt(18.0));
  GlobalProblem<2> problem(snake);
  ASSERT_TRUE(e->add_residuals(snake, 0.7, problem));
  EXPECT_EQ(problem.num_residual_blocks(), 2);
  EXPECT_NEAR(problem.sum_of_squares(), 0.7 * 26.0, 1e-12);
}

// After a remesh inserted free vertices, each landmark is found by its template id.
TEST(LandmarksEnergy, FindsLandmarkVerticesByTemplateIdAmongFreeVertices) {
  const Template<2> t = square();
  auto e = test_support::make_energy<2>(kSprings);
  PointList<2> q = {Point<2>(0, 0), Point<2>(0.5, 0), Point<2>(1, 0), Point<2>(1, 0.5), Point<2>(1, 1), Point<2>(0, 1)};
  Snake<2> snake(q, Connectivity::polygon(6), {0, -1, 1, -1, 2, 3});
  e->bind({&t}, snake);
  const auto mask = e->governed_mask();
  EXPECT_EQ(std::vector<uint8_t>(mask.begin(), mask.end()), (std::vector<uint8_t>{1, 0, 0, 0, 1, 0}));
  PointList<2> out(6, Point<2>::Zero());
  e->propose(snake, out);
  EXPECT_EQ(out[4], Point<2>(5, 5));
  EXPECT_DOUBLE_EQ(e->value(snake), 5.0 + 32.0);  // |(0,0)-(1,2)|^2 + |(1,1)-(5,5)|^2
}

// The points are world coordinates; on an oblique image the snake lives in the grid's frame.
TEST(LandmarksEnergy, PointsAreMappedFromWorldIntoTheImageFrame) {
  const Template<2> t = square();
  Grid<2> g;
  g.size = GridIndex<2>(8, 8);
  g.origin = Point<2>(3, -1);
  g.direction = Eigen::Rotation2Dd(0.6).toRotationMatrix();
  const Image<2> image(g, 0.0f);
  auto e = test_support::make_energy<2>(kSprings);
  Snake<2> snake = Snake<2>::from_template(t, t.positions);
  e->bind({&t, &image}, snake);
  PointList<2> out(4, Point<2>::Zero());
  e->propose(snake, out);
  EXPECT_LT((out[0] - g.to_frame(Point<2>(1, 2))).norm(), 1e-12);
  EXPECT_LT((g.to_world(out[2]) - Point<2>(5, 5)).norm(), 1e-12);
}

// One step of the averaged update with an internal term (weight 1) and the springs (weight 3):
// the landmark vertices go to (q_int + 3 y) / 4, the others to q_int, bit for bit as without them.
TEST(LandmarksEnergy, TheAverageMovesOnlyLandmarkVertices) {
  Template<2> t = test_support::wobbly_polygon(24, 10.0);
  t.landmarks = {{"p", 3}, {"q", 17}};
  const PointList<2> q = test_support::perturbed<2>(t.positions, 0.5, 3);
  auto step = [&](bool springs) {
    std::vector<WeightedEnergy<2>> energies;
    energies.push_back({1.0, test_support::make_energy<2>(R"({"type": "internal", "alpha": 0.3, "beta": 0.1})")});
    if (springs) energies.push_back({3.0, test_support::make_energy<2>(R"({"type": "landmarks", "points": {"p": [20, 1], "q": [-4, -15]}})")});
    Evolver<2> evolver({&t}, std::move(energies));
    Snake<2> snake = Snake<2>::from_template(t, q);
    evolver.step(snake);
    return snake.positions();
  };
  const PointList<2> alone = step(false), with = step(true);
  for (int v = 0; v < t.num_vertices(); ++v) {
    if (v == 3) EXPECT_LT((with[v] - (alone[v] + 3 * Point<2>(20, 1)) / 4).norm(), 1e-12);
    else if (v == 17) EXPECT_LT((with[v] - (alone[v] + 3 * Point<2>(-4, -15)) / 4).norm(), 1e-12);
    else EXPECT_EQ(with[v], alone[v]) << "vertex " << v;
  }
}

TEST(LandmarksEnergy, BadPointsAndUnknownNamesNameTheirPath) {
  try {
    test_support::make_energy<2>(R"({"type": "landmarks", "points": {"a": [1, 2, 3]}})");
    ADD_FAILURE() << "a 3D point accepted in 2D";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "energies[0].points.a");
    EXPECT_EQ(e.message(), "expected 2 numbers");
  }
  try {
    test_support::make_energy<3>(R"({"type": "landmarks", "points": {"a": [1, "x", 3]}})");
    ADD_FAILURE() << "a string accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "energies[0].points.a[1]");
  }
  try {
    test_support::make_energy<2>(R"({"type": "landmarks", "points": [1, 2]})");
    ADD_FAILURE() << "an array accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "energies[0].points");
  }
  auto e = test_support::make_energy<2>(R"({"type": "landmarks", "points": {"a": [0, 0], "zz": [1, 1]}})");
  try {
    e->check_template(square());
    ADD_FAILURE() << "an unknown landmark accepted";
  } catch (const OptionError& error) {
    EXPECT_EQ(error.key, "points.zz");
    EXPECT_EQ(error.message, "the template has no landmark \"zz\" (its landmarks: a, c)");
  }
}

}  // namespace
}  // namespace dsnake
