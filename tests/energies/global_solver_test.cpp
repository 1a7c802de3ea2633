// The global-solve baseline: every residual's derivatives against Ceres' numeric ones
// (GradientChecker, with the rotation manifolds), ASAP alone reaching a similarity of the
// template, and the global optimum at least as low as the snake's fixed point.
#include "framework/core/evolver.h"
#include "framework/global/global_solver.h"

#include "energies/registry.h"
#include "experiments/phantoms/phantoms.h"
#include "framework/core/external_field.h"
#include "framework/core/potential.h"

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>
#include "tests/energies/edge_images.h"
#include "tests/energy_fixtures.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>

namespace dsnake {
namespace {

using test_support::perturbed;
using test_support::wobbly_polygon;
using test_support::wobbly_sphere;
using test_support::make_energy;

// P(x) = s (|x - c| - R)^2: a smooth shell attractor (the "edge" is the sphere of radius R).
template <int D>
class ShellPotential final : public Potential<D> {
 public:
  ShellPotential(Point<D> c, double radius, double scale) : c_(c), r_(radius), s_(scale) {}
  double value(const Point<D>& x) const override {
    const double d = (x - c_).norm() - r_;
    return s_ * d * d;
  }
  double value_and_gradient(const Point<D>& x, Point<D>& g) const override {
    const double n = (x - c_).norm(), d = n - r_;
    g = 2 * s_ * d * (x - c_) / n;
    return s_ * d * d;
  }

 private:
  Point<D> c_;
  double r_, s_;
};

// The field F = -grad P of a ShellPotential, for the snake.
template <int D>
class ShellField final : public ExternalField<D> {
 public:
  explicit ShellField(const ShellPotential<D>& p) : p_(p) {}
  std::string type() const override { return "shell"; }
  void compute(const Image<D>&) override {}
  Point<D> force(const Point<D>& x, const Point<D>&) const override {
    Point<D> g;
    p_.value_and_gradient(x, g);
    return -g;
  }
  bool has_potential() const override { return true; }
  double potential(const Point<D>& x) const override { return p_.value(x); }
  const VectorField<D>& vectors() const override { return vectors_; }

 private:
  const ShellPotential<D>& p_;
  VectorField<D> vectors_;
};

// Every residual block of the problem, at a random state (positions as given, every auxiliary
// block moved to a random rotation and scale), passes Ceres' GradientChecker.
template <int D>
void check_all_residual_blocks(GlobalProblem<D>& problem, unsigned seed, const std::string& label) {
  SCOPED_TRACE(label);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int b = 0; b < problem.num_auxiliary_blocks(); ++b) {
    double* x = problem.auxiliary(b);
    const int size = problem.problem().ParameterBlockSize(x);
    if (D == 3 && size >= 4) {  // a random unit quaternion (then log-scale)
      Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
      q.normalize();
      x[0] = q.w(), x[1] = q.x(), x[2] = q.y(), x[3] = q.z();
      if (size == 5) x[4] = 0.5 * u(rng);
    } else {
      x[0] = std::numbers::pi * u(rng);
      if (size == 2) x[1] = 0.5 * u(rng);
    }
  }
  std::vector<ceres::ResidualBlockId> ids;
  problem.problem().GetResidualBlocks(&ids);
  ASSERT_FALSE(ids.empty());
  int checked = 0;
  for (auto id : ids) {
    std::vector<double*> blocks;
    problem.problem().GetParameterBlocksForResidualBlock(id, &blocks);
    std::vector<const ceres::Manifold*> manifolds;
    for (double* x : blocks) manifolds.push_back(problem.problem().GetManifold(x));
    const ceres::CostFunction* cost = problem.problem().GetCostFunctionForResidualBlock(id);
    ceres::NumericDiffOptions options;
    // Ceres' checker differentiates with Ridders' method from a 1e-2 relative step, which on
    // r = sqrt(P) at |x| ~ 10 extrapolates from steps comparable to the curvature radius and
    // misses by percents; start from 1e-4 (the extrapolation then converges to ~1e-10).
    options.ridders_relative_initial_step_size = 1e-4;
    ceres::GradientChecker checker(cost, &manifolds, options);
    ceres::GradientChecker::ProbeResults results;
    checker.Probe(blocks.data(), 1e-6, &results);
    ASSERT_TRUE(results.return_value);
    // Ceres' own verdict is relative per entry, which flags round-off in entries ~1e-16; compare
    // each block's local Jacobian with the numeric one relative to the block's largest entry.
    for (size_t b = 0; b < blocks.size(); ++b) {
      const auto& user = results.local_jacobians[b];
      const auto& numeric = results.local_numeric_jacobians[b];
      const double scale = std::max(1.0, user.cwiseAbs().maxCoeff());
      EXPECT_LE((user - numeric).cwiseAbs().maxCoeff(), 1e-6 * scale) << "block " << b << "\n" << results.error_log;
    }
    ++checked;
  }
  EXPECT_EQ(checked, problem.num_residual_blocks());
}

template <int D>
void check_energies(const Template<D>& t, const std::vector<std::string>& specs, unsigned seed) {
  const PointList<D> q = perturbed<D>(t.positions, 1.0, seed);
  Snake<D> snake = Snake<D>::from_template(t, q);
  ShellPotential<D> potential(Point<D>::Zero(), 9.0, 0.3);
  // an image with an edge near the snake, for the energies that sample one (the region term)
  const Image<D> image = test_support::radial_image<D>(D == 2 ? 48 : 32, 1.0, [](double r) { return r < 10 ? 170.0 : 85.0; }, 1.5);
  EnergyContext<D> context{&t, &image, nullptr, &potential};
  for (const auto& spec : specs) {
    auto e = make_energy<D>(spec);
    ASSERT_TRUE(e->has_least_squares_form()) << spec;
    if (e->type() != "external") e->bind(context, snake);
    else {
      ShellField<D> field(potential);
      EnergyContext<D> with_field = context;
      with_field.field = &field;
      e->bind(with_field, snake);
    }
    GlobalProblem<D> problem(snake);
    ASSERT_TRUE(e->add_residuals(snake, 0.7, problem)) << spec;
    if (problem.num_residual_blocks() == 0) {  // nothing to pull at its defaults (landmarks without points)
      EXPECT_EQ(e->value(snake), 0.0) << spec;
      continue;
    }
    check_all_residual_blocks<D>(problem, seed + 1, std::to_string(D) + "D " + spec);
  }
}

// The landmark springs (energies/landmarks.h) on templates with named vertices.
TEST(GlobalSolver, LandmarkResidualsPassTheGradientChecker) {
  Template<2> t2 = wobbly_polygon(20, 10.0);
  t2.landmarks = {{"a", 2}, {"b", 11}, {"c", 19}};
  check_energies<2>(t2, {R"({"type": "landmarks", "points": {"a": [3, -4], "b": [12, 1], "c": [-7, -2]}})"}, 31);
  Template<3> t3 = wobbly_sphere(1, 10.0);
  t3.landmarks = {{"a", 0}, {"b", 7}};
  check_energies<3>(t3, {R"({"type": "landmarks", "points": {"a": [3, -4, 1], "b": [12, 1, -5]}})"}, 32);
}

TEST(GlobalSolver, EveryResidualPassesTheGradientChecker) {
  const std::vector<std::string> specs = {
      R"({"type": "internal", "alpha": 0.6, "beta": 0.2})",
      R"({"type": "external"})",
      R"({"type": "asap_mls", "variant": "exact", "neighborhood": "k_nearest", "k": 5})",
      R"({"type": "asap_mls", "variant": "approximate", "neighborhood": "rings", "rings": 2, "falloff": 0.5})",
      R"({"type": "laplacian"})",
      R"({"type": "arap"})"};
  check_energies<2>(wobbly_polygon(20, 10.0), specs, 11);
  check_energies<3>(wobbly_sphere(1, 10.0), specs, 12);
}

// The registry walked, not a list: every registered energy with a least-squares form, from its
// defaults, passes the gradient checker (a new energy is checked the day it is registered).
template <int D>
std::vector<std::string> registered_with_residuals() {
  std::vector<std::string> specs;
  for (const auto& name : energy_registry<D>().names())
    if (energy_registry<D>().entry(name).make_default()->has_least_squares_form()) specs.push_back(R"({"type": ")" + name + "\"}");
  return specs;
}

TEST(GlobalSolver, EveryRegisteredEnergyWithResidualsPassesTheGradientCheckerAtItsDefaults) {
  const auto specs2 = registered_with_residuals<2>(), specs3 = registered_with_residuals<3>();
  EXPECT_GE(specs2.size(), 5u);  // internal, external, asap_mls, laplacian, arap at least
  check_energies<2>(wobbly_polygon(20, 10.0), specs2, 21);
  check_energies<3>(wobbly_sphere(1, 10.0), specs3, 22);
}

// Procrustes with scale (Umeyama 1991): the RMS distance from q to the best similarity image of
// p, and its scale. Written out on dynamic-size matrices: Eigen::umeyama's fixed-size 2D
// instantiation draws a spurious -Wstringop-overread from GCC 12.
template <int D>
double similarity_rms(const PointList<D>& p, const PointList<D>& q, double& scale) {
  const double n = double(p.size());
  Eigen::VectorXd mp = Eigen::VectorXd::Zero(D), mq = Eigen::VectorXd::Zero(D);
  for (size_t i = 0; i < p.size(); ++i) mp += Eigen::VectorXd(p[i]) / n, mq += Eigen::VectorXd(q[i]) / n;
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(D, D);
  double var_p = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Eigen::VectorXd dp = Eigen::VectorXd(p[i]) - mp, dq = Eigen::VectorXd(q[i]) - mq;
    cov += dq * dp.transpose() / n;
    var_p += dp.squaredNorm() / n;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::VectorXd sign = Eigen::VectorXd::Ones(D);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) sign[D - 1] = -1;
  const Eigen::MatrixXd rotation = svd.matrixU() * sign.asDiagonal() * svd.matrixV().transpose();
  scale = svd.singularValues().dot(sign) / var_p;
  const Eigen::VectorXd shift = mq - scale * rotation * mp;
  double sum = 0;
  for (size_t i = 0; i < p.size(); ++i)
    sum += (scale * rotation * Eigen::VectorXd(p[i]) + shift - Eigen::VectorXd(q[i])).squaredNorm();
  return std::sqrt(sum / n);
}

template <int D>
double bounding_diagonal(const PointList<D>& p) {
  Point<D> lo = p[0], hi = p[0];
  for (const auto& x : p) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  return (hi - lo).norm();
}

// ASAP alone, from a perturbed template: E_def falls to <= 1e-8 of its start and the result is
// a similarity of the template (not a collapse).
template <int D>
void asap_alone_reaches_a_similarity(const Template<D>& t, const std::string& spec, unsigned seed) {
  SCOPED_TRACE(std::to_string(D) + "D " + spec);
  Snake<D> snake = Snake<D>::from_template(t, perturbed<D>(t.positions, 0.15 * bounding_diagonal(t.positions) / 10, seed));
  std::vector<WeightedEnergy<D>> energies;
  energies.push_back({1.0, make_energy<D>(spec)});
  GlobalSolverOptions options;
  options.max_iterations = 500;
  options.function_tolerance = 1e-16;
  options.gradient_tolerance = 1e-16;
  options.parameter_tolerance = 1e-14;
  GlobalSolver<D> solver(EnergyContext<D>{&t}, std::move(energies), options);
  const double start = solver.energy_terms(snake)[0];
  ASSERT_GT(start, 0);
  const GlobalSolveSummary summary = solver.solve(snake);
  EXPECT_TRUE(summary.usable) << summary.message;
  const double end = solver.energy_terms(snake)[0];
  std::ostringstream ratio;
  ratio << end / start;
  ::testing::Test::RecordProperty("asap_ratio_" + std::to_string(D) + "d_" + std::to_string(seed), ratio.str());
  EXPECT_LE(end, 1e-8 * start) << summary.message;
  double scale = 0;
  const double rms = similarity_rms<D>(t.positions, snake.positions(), scale);
  EXPECT_LE(rms, 1e-4 * bounding_diagonal(t.positions));
  EXPECT_GT(scale, 0.5);
}

TEST(GlobalSolver, AsapAloneFromAPerturbedTemplateReachesASimilarity) {
  asap_alone_reaches_a_similarity<2>(wobbly_polygon(30, 10.0), R"({"type": "asap_mls", "variant": "exact", "neighborhood": "all"})", 3);
  asap_alone_reaches_a_similarity<2>(wobbly_polygon(30, 10.0), R"({"type": "asap_mls", "neighborhood": "rings", "rings": 2})", 4);
  asap_alone_reaches_a_similarity<3>(wobbly_sphere(2, 10.0), R"({"type": "asap_mls", "neighborhood": "rings", "rings": 1})", 5);
}

// On a small 2D case with a smooth potential (F = -grad P exactly), the global solve's total
// energy is at most the snake's final energy plus 1% of the snake's decrease.
TEST(GlobalSolver, ReachesAtMostTheSnakesEnergyOnASmooth2dCase) {
  const Template<2> t = wobbly_polygon(40, 10.0);
  PointList<2> start = t.positions;
  for (auto& p : start) p = 1.3 * p + Point<2>(1.0, -0.5);
  const ShellPotential<2> potential(Point<2>(0.5, 0.0), 11.0, 1.0);
  ShellField<2> field(potential);
  EnergyContext<2> context{&t, nullptr, &field, &potential};
  const auto energies = [] {
    std::vector<WeightedEnergy<2>> e;
    // umbrella: a value quadratic in q, so that Ceres' final cost is the value at the solution
    // (the physical form's residuals freeze M and K at the start of the solve)
    e.push_back({1.0, make_energy<2>(R"({"type": "internal", "alpha": 0.3, "beta": 0.0, "discretization": "umbrella"})")});
    e.push_back({0.4, make_energy<2>(R"({"type": "external", "tau": 0.5})")});
    e.push_back({0.5, make_energy<2>(R"({"type": "asap_mls", "variant": "exact", "neighborhood": "k_nearest", "k": 6})")});
    return e;
  };
  const auto total = [](const std::vector<double>& terms) {
    double s = 0;
    for (double x : terms) s += x;
    return s;
  };
  Snake<2> snake = Snake<2>::from_template(t, start);
  Evolver<2> evolver(context, energies());
  const double e0 = total(evolver.energy_terms(snake));
  std::vector<Phase<2>> phases(1);
  phases[0].iterations = 3000;
  phases[0].tolerance = 1e-9;
  evolver.run(snake, phases);
  const double snake_energy = total(evolver.energy_terms(snake));
  ASSERT_LT(snake_energy, e0);

  Snake<2> global = Snake<2>::from_template(t, start);
  GlobalSolverOptions options;
  options.max_iterations = 500;
  GlobalSolver<2> solver(context, energies(), options);
  std::vector<Phase<2>> global_phases(1);
  const EvolveSummary summary = solver.run(global, global_phases);
  EXPECT_NE(summary.status, EvolveStatus::kDiverged);
  const double global_energy = total(solver.energy_terms(global));
  RecordProperty("start_energy", std::to_string(e0));
  RecordProperty("snake_energy", std::to_string(snake_energy));
  RecordProperty("global_energy", std::to_string(global_energy));
  EXPECT_LE(global_energy, snake_energy + 0.01 * (e0 - snake_energy))
      << "start " << e0 << ", snake " << snake_energy << ", global " << global_energy;
  ASSERT_EQ(solver.solves().size(), 1u);
  EXPECT_GT(solver.solves()[0][0].iterations, 0);
  EXPECT_NEAR(solver.solves()[0][0].final_cost, global_energy, 1e-6 * (1 + global_energy));
}

// Records each iteration's enclosed-area share of the run's start.
class ShareObserver : public EvolverObserver<2> {
 public:
  explicit ShareObserver(const PhaseDriver<2>& driver) : driver_(driver) {}
  void on_iteration(const IterationInfo&, const Snake<2>& snake) override { shares.push_back(driver_.size_share(snake)); }
  std::vector<double> shares;

 private:
  const PhaseDriver<2>& driver_;
};

// The watchdog in the global solve: the tension alone has its minimum at a point, so the solve
// collapses the polygon; it stops at the first Ceres iteration whose area share is below
// min_size, with the positions of the iteration before (every reported share passed).
TEST(GlobalSolver, ACollapseStopsTheSolveAtThatIteration) {
  const Template<2> t = wobbly_polygon(40, 10.0);
  auto energies = [] {
    std::vector<WeightedEnergy<2>> e;
    e.push_back({1.0, make_energy<2>(R"({"type": "internal", "alpha": 5, "beta": 0.0, "discretization": "umbrella"})")});
    return e;
  };
  GlobalSolverOptions options;
  options.max_iterations = 200;
  std::vector<Phase<2>> phases(1);
  // Without the check: the share falls below 1e-3 at some iteration k (found here).
  GlobalSolver<2> free_solver(EnergyContext<2>{&t}, energies(), options);
  ShareObserver free_shares(free_solver);
  free_solver.add_observer(&free_shares);
  Snake<2> free_snake = Snake<2>::from_template(t, t.positions);
  free_solver.run(free_snake, phases);
  const auto below = std::find_if(free_shares.shares.begin(), free_shares.shares.end(), [](double x) { return x < 1e-3; });
  ASSERT_NE(below, free_shares.shares.end()) << "the tension did not collapse the polygon";
  const int k = int(below - free_shares.shares.begin()) + 1;
  // With it: diverged at k, the positions of iteration k - 1.
  GlobalSolver<2> solver(EnergyContext<2>{&t}, energies(), options);
  Watchdog w;
  w.min_size = 1e-3;
  solver.set_watchdog(w);
  ShareObserver shares(solver);
  solver.add_observer(&shares);
  Snake<2> snake = Snake<2>::from_template(t, t.positions);
  const EvolveSummary summary = solver.run(snake, phases);
  EXPECT_EQ(summary.status, EvolveStatus::kDiverged);
  ASSERT_TRUE(summary.phases[0].divergence.has_value());
  const Divergence& d = *summary.phases[0].divergence;
  EXPECT_EQ(d.phase_iteration, k);
  EXPECT_NEAR(*d.size_share, *below, 1e-12);
  EXPECT_GE(solver.size_share(snake), 1e-3);
  EXPECT_NEAR(solver.size_share(snake), k > 1 ? free_shares.shares[k - 2] : 1.0, 1e-12);
  for (double x : shares.shares) EXPECT_GE(x, 1e-3);
}

// The bounds on the global solve: max_iterations per solve, and max_time_s over the whole solve,
// whose end stops the run as diverged, naming the key.
TEST(GlobalSolver, StopsAtItsIterationAndTimeBounds) {
  const Template<2> t = wobbly_polygon(40, 10.0);
  auto energies = [] {
    std::vector<WeightedEnergy<2>> e;
    e.push_back({1.0, make_energy<2>(R"({"type": "internal", "alpha": 0.3, "beta": 0.0, "discretization": "umbrella"})")});
    e.push_back({0.5, make_energy<2>(R"({"type": "asap_mls", "variant": "exact", "neighborhood": "k_nearest", "k": 6})")});
    return e;
  };
  PointList<2> start = t.positions;
  for (auto& p : start) p = 1.3 * p;
  std::vector<Phase<2>> phases(2);
  GlobalSolverOptions options;
  options.max_iterations = 3;
  options.function_tolerance = options.gradient_tolerance = options.parameter_tolerance = 0;
  GlobalSolver<2> few(EnergyContext<2>{&t}, energies(), options);
  Snake<2> a = Snake<2>::from_template(t, start);
  const EvolveSummary s = few.run(a, phases);
  EXPECT_NE(s.status, EvolveStatus::kDiverged);
  ASSERT_EQ(s.phases.size(), 2u);
  for (const auto& ps : s.phases) EXPECT_EQ(ps.iterations, 3);  // no tolerance stops it earlier
  // (Ceres' summary also counts the step it stopped on.)
  for (const auto& solve : few.solves()) EXPECT_LE(solve[0].iterations, 4);
  options.max_iterations = 1000;
  options.max_time_s = 1e-9;  // past after Ceres' first iteration
  GlobalSolver<2> timed(EnergyContext<2>{&t}, energies(), options);
  Snake<2> b = Snake<2>::from_template(t, start);
  const EvolveSummary bounded = timed.run(b, phases);
  EXPECT_EQ(bounded.status, EvolveStatus::kDiverged);
  ASSERT_EQ(bounded.phases.size(), 1u);  // the second phase does not start
  ASSERT_TRUE(bounded.phases[0].divergence.has_value());
  EXPECT_EQ(bounded.phases[0].divergence->term, "global");
  EXPECT_NE(bounded.phases[0].divergence->reason.find("global.max_time_s"), std::string::npos);
  EXPECT_LE(bounded.phases[0].iterations, 1);
  for (const auto& p : b.positions()) EXPECT_TRUE(p.allFinite());
}

}  // namespace
}  // namespace dsnake
