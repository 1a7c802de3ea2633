// The global view: residual blocks whose squares sum to the energy's value, with derivatives
// that agree with finite differences of value().
#include "framework/global/global_problem.h"

#include "energies/internal.h"
#include "experiments/phantoms/phantoms.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <random>

namespace dsnake {
namespace {

template <int D>
void expect_residuals_match_value(const Snake<D>& snake, InternalOptions options, double weight) {
  // The umbrella form, whose value is quadratic in q: the finite-difference gradient below is
  // then the residuals' (the physical form's residuals freeze M and K; tests/energies checks them).
  options.discretization = InternalDiscretization::kUmbrella;
  InternalEnergy<D> energy(options);
  energy.bind({}, snake);
  GlobalProblem<D> problem(snake);
  ASSERT_TRUE(energy.add_residuals(snake, weight, problem));
  const double value = energy.value(snake);
  EXPECT_NEAR(problem.sum_of_squares(), weight * value, 1e-10 * (1 + weight * value));

  // Ceres' gradient of 1/2 sum r^2 equals weight / 2 times the finite-difference gradient of value().
  double cost = 0;
  std::vector<double> gradient;
  problem.problem().Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, &gradient, nullptr);
  ASSERT_EQ(gradient.size(), size_t(snake.num_vertices()) * D);
  const double h = 1e-6;
  for (int v = 0; v < snake.num_vertices(); v += 3) {
    for (int a = 0; a < D; ++a) {
      Snake<D> plus = snake, minus = snake;
      plus.positions()[v][a] += h;
      minus.positions()[v][a] -= h;
      const double fd = (energy.value(plus) - energy.value(minus)) / (2 * h);
      EXPECT_NEAR(gradient[size_t(v) * D + a], 0.5 * weight * fd, 1e-5 * (1 + std::abs(fd)));
    }
  }
}

TEST(GlobalProblem, InternalResidualsSumToTheValue2d) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.3);
  Template<2> t;
  for (int k = 0; k < 9; ++k)
    t.positions.emplace_back(5 * std::cos(0.7 * k) + noise(rng), 5 * std::sin(0.7 * k) + noise(rng));
  t.connectivity = Connectivity::polygon(9);
  const Snake<2> snake = Snake<2>::from_template(t, t.positions);
  expect_residuals_match_value(snake, {0.7, 0.3, 1.0}, 1.0);
  expect_residuals_match_value(snake, {0.2, 0.0, 1.0}, 2.5);
}

TEST(GlobalProblem, InternalResidualsSumToTheValue3d) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.05);
  Template<3> t = make_icosphere(1);
  for (auto& p : t.positions) p += Point<3>(noise(rng), noise(rng), noise(rng));
  const Snake<3> snake = Snake<3>::from_template(t, t.positions);
  expect_residuals_match_value(snake, {0.5, 0.2, 1.0}, 0.8);
}

TEST(GlobalProblem, ParametersStartAtTheSnakeAndLinearResidualsAreExact) {
  Template<2> t{{{0, 0}, {2, 0}, {1, 3}}, Connectivity::polygon(3), {}};
  const Snake<2> snake = Snake<2>::from_template(t, t.positions);
  GlobalProblem<2> problem(snake);
  EXPECT_EQ(problem.positions(), snake.positions());
  const int vertices[2] = {2, 1};
  const double coefficients[2] = {1.0, -0.5};
  problem.add_linear_residual(vertices, coefficients, 2.0);
  // r = 2 ((1, 3) - 0.5 (2, 0)) = (0, 6).
  EXPECT_NEAR(problem.sum_of_squares(), 36.0, 1e-12);
  EXPECT_EQ(problem.num_residual_blocks(), 1);
}

}  // namespace
}  // namespace dsnake
