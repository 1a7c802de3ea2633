// Laplacian, ARAP and balloon energies (invariances, snake steps), and the global view of every
// deformation energy: sum of squared residuals == value, residual gradients == finite differences
// of the value.
#include "energies/arap.h"
#include "energies/asap_mls.h"
#include "energies/balloon.h"
#include "energies/laplacian.h"
#include "energies/registry.h"
#include "experiments/phantoms/phantoms.h"
#include "framework/core/errors.h"
#include "framework/global/global_problem.h"

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <cmath>
#include <numbers>
#include "tests/energy_fixtures.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <random>

namespace dsnake {
namespace {

using test_support::perturbed;
using test_support::wobbly_polygon;
using test_support::wobbly_sphere;
using test_support::make_energy;

// ARAP: zero for rigid motions (rotations + translations), positive under scaling; 2D and 3D.
TEST(Arap, RigidMotionsAreFreeScalingIsNot) {
  const Template<2> t2 = wobbly_polygon(30);
  const Template<3> t3 = wobbly_sphere(1);
  ArapEnergy<2> e2;
  ArapEnergy<3> e3;
  PointList<2> q2;
  const Eigen::Matrix2d r2 = Eigen::Rotation2Dd(2.1).toRotationMatrix();
  for (const auto& p : t2.positions) q2.push_back(r2 * p + Point<2>(5, -7));
  Snake<2> s2 = Snake<2>::from_template(t2, q2);
  e2.bind({&t2}, s2);
  EXPECT_LT(e2.value(s2), 1e-20 * 1e4);
  for (auto& x : s2.positions()) x *= 1.1;
  EXPECT_GT(e2.value(s2), 1.0);
  const Eigen::Matrix3d r3 = Eigen::AngleAxisd(1.3, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  PointList<3> q3;
  for (const auto& p : t3.positions) q3.push_back(r3 * p + Point<3>(5, -7, 2));
  Snake<3> s3 = Snake<3>::from_template(t3, q3);
  e3.bind({&t3}, s3);
  EXPECT_LT(e3.value(s3), 1e-20 * 1e4);
  // scaling by 1.1 about the origin: every edge residual is 0.1 |e| at the optimal rotation I
  double expected = 0;
  for (int i = 0; i < t3.num_vertices(); ++i)
    for (int j : t3.connectivity.neighbors(i)) expected += 0.01 * (t3.positions[i] - t3.positions[j]).squaredNorm();
  for (int v = 0; v < t3.num_vertices(); ++v) s3.positions()[v] = 1.1 * t3.positions[v];
  EXPECT_NEAR(e3.value(s3), expected, 1e-9 * expected);
}

// ARAP snake step: a rigid motion is a fixed point, and from a perturbed start the steps decrease
// the energy (local-global alternation, Sorkine & Alexa 2007).
TEST(Arap, SnakeStepsDecreaseTheEnergy) {
  const Template<3> t = wobbly_sphere(1);
  ArapEnergy<3> e;
  Snake<3> s = Snake<3>::from_template(t, perturbed<3>(t.positions, 1.0, 3));
  e.bind({&t}, s);
  const double first = e.value(s);
  PointList<3> out(s.num_vertices());
  for (int it = 0; it < 30; ++it) {
    e.propose(s, out);
    s.positions() = out;
  }
  EXPECT_LT(e.value(s), 0.2 * first);
  Snake<3> rigid = Snake<3>::from_template(t, t.positions);
  e.propose(rigid, out);
  for (int v = 0; v < t.num_vertices(); ++v) EXPECT_LT((out[v] - t.positions[v]).norm(), 1e-9);
}

// Laplacian editing: translations (and uniform scalings) give zero energy; a perturbation does not.
TEST(Laplacian, TranslationsAreFree) {
  const Template<2> t2 = wobbly_polygon(30);
  const Template<3> t3 = wobbly_sphere(1);
  LaplacianEnergy<2> e2;
  LaplacianEnergy<3> e3;
  PointList<2> q2;
  for (const auto& p : t2.positions) q2.push_back(p + Point<2>(40, -3));
  Snake<2> s2 = Snake<2>::from_template(t2, q2);
  e2.bind({&t2}, s2);
  EXPECT_LT(e2.value(s2), 1e-18);
  PointList<3> q3;
  for (const auto& p : t3.positions) q3.push_back(2.0 * p + Point<3>(40, -3, 8));
  Snake<3> s3 = Snake<3>::from_template(t3, q3);
  e3.bind({&t3}, s3);
  EXPECT_LT(e3.value(s3), 1e-16);
  s3.positions() = perturbed<3>(q3, 0.5, 1);
  EXPECT_GT(e3.value(s3), 1e-2);
  // Gauss-Seidel sweeps are exact coordinate descent on the quadratic form: never increasing
  auto gs = make_energy<3>(R"({"type": "laplacian", "iteration": "gauss_seidel"})");
  gs->bind({&t3}, s3);
  PointList<3> out(s3.num_vertices());
  double prev = gs->value(s3);
  for (int it = 0; it < 20; ++it) {
    gs->propose(s3, out);
    s3.positions() = out;
    const double now = gs->value(s3);
    EXPECT_LE(now, prev * (1 + 1e-12));
    prev = now;
  }
}

// Balloon: the proposal moves every vertex by `pressure` along its outward normal; a circle of
// radius r becomes (nearly) radius r + pressure; the value is -pressure x area.
TEST(Balloon, PushesAlongTheNormal) {
  Template<2> t;
  for (int i = 0; i < 64; ++i) t.positions.push_back(Point<2>(5 * std::cos(2 * std::numbers::pi * i / 64), 5 * std::sin(2 * std::numbers::pi * i / 64)));
  t.connectivity = Connectivity::polygon(64);
  for (double pressure : {0.5, -0.5}) {
    auto e = make_energy<2>(R"({"type": "balloon", "pressure": )" + std::to_string(pressure) + "}");
    Snake<2> s = Snake<2>::from_template(t, t.positions);
    e->bind({&t}, s);
    PointList<2> out(64);
    e->propose(s, out);
    for (const auto& x : out) EXPECT_NEAR(x.norm(), 5 + pressure, 1e-12);
    EXPECT_NEAR(e->value(s), -pressure * s.signed_measure(), 1e-12);
  }
  const auto spec = nlohmann::json::parse(R"({"type": "balloon", "pressure": 0})");
  JsonReader r(spec, "test.json", "energies[2]");
  try {
    energy_registry<3>().create(r);
    ADD_FAILURE() << "pressure 0 accepted";
  } catch (const InputError& err) {
    EXPECT_EQ(err.where(), "energies[2].pressure");
  }
}

// The global view: sum of squared residuals (weight w) == w value, and the gradient that Ceres
// assembles from the residual Jacobians (J^T r) == half the finite-difference gradient of w value.
template <int D>
void check_residuals(Energy<D>& e, const Template<D>& t, const PointList<D>& q, const std::string& label) {
  SCOPED_TRACE(label);
  Snake<D> s = Snake<D>::from_template(t, q);
  e.bind({&t}, s);
  const double weight = 0.7;
  GlobalProblem<D> problem(s);
  ASSERT_TRUE(e.add_residuals(s, weight, problem));
  const double value = e.value(s);
  ASSERT_GT(value, 0);
  EXPECT_NEAR(problem.sum_of_squares(), weight * value, 1e-9 * weight * value);
  double cost = 0;
  std::vector<double> gradient;
  ceres::Problem::EvaluateOptions options;
  for (int v = 0; v < s.num_vertices(); ++v) options.parameter_blocks.push_back(problem.vertex(v));
  problem.problem().Evaluate(options, &cost, nullptr, &gradient, nullptr);
  double max_gradient = 0, max_error = 0;
  for (int v = 0; v < s.num_vertices(); ++v)
    for (int a = 0; a < D; ++a) {
      Snake<D> probe = s;
      const double h = 1e-5;
      probe.positions()[v][a] += h;
      const double up = e.value(probe);
      probe.positions()[v][a] -= 2 * h;
      const double down = e.value(probe);
      const double fd = 0.5 * weight * (up - down) / (2 * h);  // d(cost)/dq, cost = 1/2 sum r^2
      max_gradient = std::max(max_gradient, std::abs(fd));
      max_error = std::max(max_error, std::abs(fd - gradient[size_t(v) * D + a]));
    }
  EXPECT_LT(max_error, 1e-6 * (1 + max_gradient)) << "largest gradient " << max_gradient;
}

TEST(Residuals, SumOfSquaresIsTheValueAndGradientsMatch) {
  const Template<2> t2 = wobbly_polygon(24);
  const Template<3> t3 = wobbly_sphere(1);
  const PointList<2> q2 = perturbed<2>(t2.positions, 1.5, 7);
  const PointList<3> q3 = perturbed<3>(t3.positions, 1.5, 8);
  for (const char* json : {R"({"type": "asap_mls", "variant": "exact", "neighborhood": "k_nearest", "k": 5})",
                           R"({"type": "asap_mls", "neighborhood": "rings", "rings": 2, "falloff": 0.5})",
                           R"({"type": "laplacian"})", R"({"type": "arap"})"}) {
    check_residuals<2>(*make_energy<2>(json), t2, q2, std::string("2D ") + json);
    check_residuals<3>(*make_energy<3>(json), t3, q3, std::string("3D ") + json);
  }
  // balloon and the volume-type energies have no least-squares form
  Snake<3> s = Snake<3>::from_template(t3, q3);
  GlobalProblem<3> problem(s);
  EXPECT_FALSE(make_energy<3>(R"({"type": "balloon"})")->add_residuals(s, 1.0, problem));
}

}  // namespace
}  // namespace dsnake
