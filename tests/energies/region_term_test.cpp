// The region term (energies/region_term.h, Chan & Vese 2001) on images with known answers: a
// blurred two-level disk (bright or dark inside) reached from inside and outside, the band means
// on a sharp two-level image, the proposals unchanged by an affine change of the intensities, its
// residuals against Ceres' numeric derivatives and its value, a blurred ball in 3D, no move on a
// flat image, bad keys, and the same bits for 1 and 2 threads.
#include "energies/region_term.h"

#include "framework/core/errors.h"
#include "framework/global/global_problem.h"
#include "framework/global/global_solver.h"
#include "tests/energies/edge_images.h"
#include "tests/energy_fixtures.h"

#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace dsnake {
namespace {

using namespace test_support;

// `inside` within `radius`, `outside` beyond.
std::function<double(double)> two_level(double radius, double inside = 170.0, double outside = 85.0) {
  return [=](double r) { return r < radius ? inside : outside; };
}

// The radial component of each vertex's move, (out_v - q_v) . q_v / |q_v| (a circle or sphere
// about the origin), its smallest and largest.
template <int D>
std::pair<double, double> radial_moves(const Snake<D>& snake, const PointList<D>& out) {
  double lo = INFINITY, hi = -INFINITY;
  for (int v = 0; v < snake.num_vertices(); ++v) {
    const Point<D>& q = snake.positions()[v];
    const double m = (out[v] - q).dot(q.normalized());
    lo = std::min(lo, m), hi = std::max(hi, m);
  }
  return {lo, hi};
}

// A disk of radius 10 mm, 170 on 85 (and 85 on 170), blurred by 1.5 mm on a 1 mm grid; circles
// started 3 mm outside and inside. The first proposals point inwards (outside start) or outwards
// (inside start) at every vertex; 60 iterations of the term alone end on r = 10: the half level
// of the blurred disk, inside r = 10 by the blur of a curved edge (blurred_edge_radius: 0.16 mm).
TEST(RegionTermEnergy, Disk2DProposalsPointToTheEdgeAndTheRunEndsOnIt) {
  for (auto [inside, outside] : {std::pair{170.0, 85.0}, std::pair{85.0, 170.0}}) {
    const Image<2> image = radial_image<2>(64, 1.0, two_level(10.0, inside, outside), 1.5);
    for (double start : {13.0, 7.0}) {
      SCOPED_TRACE(std::to_string(inside) + " inside, from r = " + std::to_string(start));
      const Template<2> t = round_template<2>(start);
      Snake<2> snake = Snake<2>::from_template(t, t.positions);
      RegionTermEnergy<2> energy;
      energy.bind(EnergyContext<2>{&t, &image}, snake);
      PointList<2> out(snake.num_vertices());
      energy.propose(snake, out);
      const auto [lo, hi] = radial_moves(snake, out);
      if (start > 10) EXPECT_LT(hi, -0.2);  // inwards, by at least 0.2 mm (step 0.5 mm)
      else EXPECT_GT(lo, 0.2);              // outwards
      iterate_alone<2>(energy, EnergyContext<2>{&t, &image}, snake, 60);
      const auto [mean, worst] = radial_error(snake, 10.0);
      const double offset = mean_radial_offset(snake, 10.0);
      std::printf("region 2D %.0f on %.0f from r = %.0f: mean |r - 10| %.3f, largest %.3f, mean offset %.3f; "
                  "c_in %.2f, c_out %.2f\n", inside, outside, start, mean, worst, offset, energy.c_in(), energy.c_out());
      EXPECT_LT(worst, 0.3);                   // within 0.3 px of the true radius
      EXPECT_NEAR(offset, -0.16, 0.1);         // on the blurred disk's half level
      // the band means of a straight edge blurred by s = 1.8 mm (1.5 and the energy's 1 mm):
      // each moves towards the other level by (s / band) (B Phi(-B) + phi(0) - phi(B)) = 0.2275
      // of the contrast, B = band / s; their mean stays the half level
      EXPECT_NEAR(energy.c_in() + energy.c_out(), inside + outside, 1.0);
      EXPECT_NEAR(energy.c_in() - energy.c_out(), (inside - outside) * (1 - 2 * 0.2275), 2.0);
    }
  }
}

// A sharp disk (170 on 85, radius 10 mm, no blur, 0.1 mm voxels), band 4 mm, sigma 0: a circle
// on the edge has c_in = 170 and c_out = 85 within 1% (only the samples in the voxel straddling
// the edge mix); a circle at r = 13 has an inside band [9, 13] a quarter in the disk,
// c_in = (170 + 3 * 85) / 4 = 106.25, and c_out = 85.
TEST(RegionTermEnergy, BandMeansOnASharpTwoLevelImage) {
  const Image<2> image = radial_image<2>(320, 0.1, two_level(10.0), 0.0);
  RegionTermOptions o;
  o.sigma = 0.0;
  o.band = 4.0;
  for (auto [start, c_in] : {std::pair{10.0, 170.0}, std::pair{13.0, 106.25}}) {
    const Template<2> t = round_template<2>(start, Point<2>::Zero(), 96);
    const Snake<2> snake = Snake<2>::from_template(t, t.positions);
    RegionTermEnergy<2> energy(o);
    energy.bind(EnergyContext<2>{&t, &image}, snake);
    std::printf("region means at r = %.0f: c_in %.3f (expected %.2f), c_out %.3f (85)\n", start, energy.c_in(), c_in,
                energy.c_out());
    EXPECT_EQ(energy.samples(), 80);  // 4 mm / 0.05 mm
    EXPECT_NEAR(energy.c_in(), c_in, 0.01 * c_in) << start;
    EXPECT_NEAR(energy.c_out(), 85.0, 0.01 * 85.0) << start;
  }
}

// The blurred disk with intensities on a 1/64 lattice (so that 10 I + 1000 and 255 - I are
// exact floats), sigma 0: the proposals of a perturbed circle are the same for I, 10 I + 1000 and
// 255 - I (the contrast flips: no polarity to set) to 1e-9 of the step, and c follows the map.
TEST(RegionTermEnergy, ProposalsDoNotChangeWithAnAffineIntensityMap) {
  Image<2> image = radial_image<2>(64, 1.0, two_level(10.0), 1.5);
  for (int64_t l = 0; l < image.num_voxels(); ++l) image[l] = std::round(image[l] * 64.0f) / 64.0f;
  const Template<2> t = round_template<2>(12.0);
  const Snake<2> snake = Snake<2>::from_template(t, perturbed<2>(t.positions, 1.0, 7));
  RegionTermOptions o;
  o.sigma = 0.0;
  auto propose = [&](double a, double b, RegionTermEnergy<2>& energy) {
    Image<2> mapped = image;
    for (int64_t l = 0; l < mapped.num_voxels(); ++l) mapped[l] = static_cast<float>(a * image[l] + b);
    energy.bind(EnergyContext<2>{&t, &mapped}, snake);
    PointList<2> out(snake.num_vertices());
    energy.propose(snake, out);
    return out;
  };
  RegionTermEnergy<2> plain(o);
  const PointList<2> reference = propose(1.0, 0.0, plain);
  double largest = 0.0;
  for (int v = 0; v < snake.num_vertices(); ++v) largest = std::max(largest, (reference[v] - snake.positions()[v]).norm());
  EXPECT_GT(largest, 0.1);
  for (auto [a, b] : {std::pair{10.0, 1000.0}, std::pair{-1.0, 255.0}}) {
    SCOPED_TRACE(std::to_string(a) + " I + " + std::to_string(b));
    RegionTermEnergy<2> energy(o);
    const PointList<2> out = propose(a, b, energy);
    double worst = 0.0;
    for (int v = 0; v < snake.num_vertices(); ++v) worst = std::max(worst, (out[v] - reference[v]).norm());
    EXPECT_LE(worst, 1e-9 * o.step);
    EXPECT_NEAR(energy.c_in(), a * plain.c_in() + b, 1e-9 * std::abs(energy.c_in()));
    EXPECT_NEAR(energy.c_out(), a * plain.c_out() + b, 1e-9 * std::abs(energy.c_out()));
  }
}

// Every residual block against Ceres' numeric Jacobians (Ridders from a 1e-4 relative step, as
// tests/energies/global_solver_test.cpp), at positions and means moved off the add point, each
// parameter block's error relative to its largest entry.
template <int D>
void expect_residuals_pass_the_gradient_checker(GlobalProblem<D>& problem, const PointList<D>& moved) {
  for (int v = 0; v < problem.num_vertices(); ++v)
    for (int a = 0; a < D; ++a) problem.vertex(v)[a] = moved[v][a];
  ASSERT_EQ(problem.num_auxiliary_blocks(), 1);
  problem.auxiliary(0)[0] += 7.0, problem.auxiliary(0)[1] -= 5.0;  // the means off their start too
  std::vector<ceres::ResidualBlockId> ids;
  problem.problem().GetResidualBlocks(&ids);
  ASSERT_EQ(int(ids.size()), problem.num_vertices());
  ceres::NumericDiffOptions options;
  options.ridders_relative_initial_step_size = 1e-4;
  const std::vector<const ceres::Manifold*>* euclidean = nullptr;
  for (auto id : ids) {
    std::vector<double*> blocks;
    problem.problem().GetParameterBlocksForResidualBlock(id, &blocks);
    const ceres::GradientChecker checker(problem.problem().GetCostFunctionForResidualBlock(id), euclidean, options);
    ceres::GradientChecker::ProbeResults results;
    checker.Probe(blocks.data(), 1e-6, &results);
    ASSERT_TRUE(results.return_value);
    ASSERT_EQ(blocks.size(), 2u);  // the means, the vertex
    for (size_t b = 0; b < blocks.size(); ++b) {
      const auto& user = results.jacobians[b];
      const double scale = std::max(1e-3, user.cwiseAbs().maxCoeff());
      EXPECT_LE((user - results.numeric_jacobians[b]).cwiseAbs().maxCoeff(), 1e-6 * scale) << b << results.error_log;
    }
  }
}

// The residuals' squares sum to weight x value at the add point, in 2D and 3D (one block per
// vertex, one shared block of means); their Jacobians pass the gradient checker up to 0.4 mm off
// it in random directions.
template <int D>
void check_residuals(const Image<D>& image, const Template<D>& t) {
  SCOPED_TRACE(std::to_string(D) + "D");
  const Snake<D> snake = Snake<D>::from_template(t, perturbed<D>(t.positions, 0.5, 11));
  RegionTermEnergy<D> energy;
  energy.bind(EnergyContext<D>{&t, &image}, snake);
  const double value = energy.value(snake);
  EXPECT_GT(value, 0.0);
  GlobalProblem<D> problem(snake);
  ASSERT_TRUE(energy.add_residuals(snake, 0.7, problem));
  EXPECT_EQ(problem.num_residual_blocks(), snake.num_vertices());
  EXPECT_NEAR(problem.sum_of_squares(), 0.7 * value, 1e-10 * value);
  expect_residuals_pass_the_gradient_checker<D>(problem, perturbed<D>(snake.positions(), 0.4, 12));
}

TEST(RegionTermEnergy, ResidualsSumToTheValueAndPassTheGradientChecker) {
  check_residuals<2>(radial_image<2>(64, 1.0, two_level(10.0), 1.5), round_template<2>(11.0));
  check_residuals<3>(radial_image<3>(36, 0.8, two_level(8.0), 1.2), round_template<3>(9.0));
}

// A ball of radius 8 mm (170 on 85) on a 0.8 mm grid, blurred by 1.2 mm; spheres of 642 vertices
// started at 11 and 5.5 mm end on it within 0.5 voxel (0.4 mm) at every vertex, on its half
// level (0.31 mm inside r = 8, blurred_edge_radius).
TEST(RegionTermEnergy, Ball3DEndsOnTheBall) {
  const Image<3> image = radial_image<3>(36, 0.8, two_level(8.0), 1.2);
  for (double start : {11.0, 5.5}) {
    SCOPED_TRACE(start);
    const Template<3> t = round_template<3>(start);
    Snake<3> snake = Snake<3>::from_template(t, t.positions);
    RegionTermEnergy<3> energy;
    iterate_alone<3>(energy, EnergyContext<3>{&t, &image}, snake, 60);
    const auto [mean, worst] = radial_error(snake, 8.0);
    const double offset = mean_radial_offset(snake, 8.0);
    std::printf("region 3D from r = %.1f: mean |r - 8| %.3f, largest %.3f, mean offset %.3f\n", start, mean, worst, offset);
    EXPECT_LT(worst, 0.4);
    EXPECT_NEAR(offset, -0.31, 0.15);
  }
}

// A flat image: no contrast, so no move, no energy and no residuals.
TEST(RegionTermEnergy, FlatImageGivesNoMoveAndNoEnergy) {
  const Image<2> image = radial_image<2>(32, 1.0, [](double) { return 100.0; }, 0.0);
  const Template<2> t = round_template<2>(6.0);
  const Snake<2> snake = Snake<2>::from_template(t, perturbed<2>(t.positions, 0.5, 2));
  RegionTermEnergy<2> energy;
  energy.bind(EnergyContext<2>{&t, &image}, snake);
  PointList<2> out(snake.num_vertices());
  energy.propose(snake, out);
  for (int v = 0; v < snake.num_vertices(); ++v) EXPECT_EQ(out[v], snake.positions()[v]);
  EXPECT_EQ(energy.value(snake), 0.0);
  GlobalProblem<2> problem(snake);
  EXPECT_TRUE(energy.add_residuals(snake, 1.0, problem));
  EXPECT_EQ(problem.num_residual_blocks(), 0);
}

// Bad keys are refused with the JSON path of the key.
TEST(RegionTermEnergy, BadKeysNameTheirPath) {
  expect_refused_at<2>({{R"({"type": "region", "step": 0})", "energies[0].step"},
                        {R"({"type": "region", "band": 0})", "energies[0].band"},
                        {R"({"type": "region", "band": -2})", "energies[0].band"},
                        {R"({"type": "region", "sigma": -1})", "energies[0].sigma"},
                        {R"({"type": "region", "spacing": -0.5})", "energies[0].spacing"},
                        {R"({"type": "region", "lambda_in": 0})", "energies[0].lambda_in"},
                        {R"({"type": "region", "lambda_out": -1})", "energies[0].lambda_out"},
                        {R"({"type": "region", "lambda_out": "big"})", "energies[0].lambda_out"},
                        {R"({"type": "region", "polarity": "auto"})", "energies[0].polarity"}});
}

// One and two threads give the same proposals, bit for bit (a perturbed 642-vertex sphere).
TEST(RegionTermEnergy, SameBitsForOneAndTwoThreads) {
  const Image<3> image = radial_image<3>(32, 1.0, two_level(8.0), 1.0);
  const Template<3> t = round_template<3>(9.5);
  const Snake<3> snake = Snake<3>::from_template(t, perturbed<3>(t.positions, 0.7, 3));
  expect_same_proposals_at_one_and_two_threads<3>([] { return RegionTermEnergy<3>(); }, EnergyContext<3>{&t, &image}, snake);
}


// One global solve (Ceres) of the term alone on the blurred disk: from the snake view's fixed
// point it stays there (the views share it), and from 0.5 mm and 1 mm outside it moves towards
// the edge but, its band anchored at the start, stops short (about half of the offset left).
// Sparse Schur with the shared means block gives the same result as the default solver.
TEST(RegionTermEnergy, GlobalSolveSharesTheSnakeViewsFixedPoint) {
  const Image<2> image = radial_image<2>(64, 1.0, two_level(10.0), 1.5);
  auto solve = [&](Snake<2>& snake, const Template<2>& t, LinearSolver linear_solver) {
    std::vector<WeightedEnergy<2>> energies;
    energies.push_back({1.0, std::make_unique<RegionTermEnergy<2>>()});
    GlobalSolverOptions options;
    options.linear_solver = linear_solver;
    GlobalSolver<2> solver(EnergyContext<2>{&t, &image}, std::move(energies), options);
    const GlobalSolveSummary summary = solver.solve(snake);
    EXPECT_TRUE(summary.usable) << summary.message;
    return mean_radial_offset(snake, 10.0);
  };
  const Template<2> t = round_template<2>(13.0);
  Snake<2> snake = Snake<2>::from_template(t, t.positions);
  RegionTermEnergy<2> energy;
  iterate_alone<2>(energy, EnergyContext<2>{&t, &image}, snake, 60);
  const double fixed = mean_radial_offset(snake, 10.0);
  const double after = solve(snake, t, LinearSolver::kSparseNormalCholesky);
  std::printf("region global from the snake's fixed point %.3f: %.3f\n", fixed, after);
  EXPECT_NEAR(after, fixed, 0.05);
  for (double start : {10.5, 11.0}) {
    const Template<2> s = round_template<2>(start);
    Snake<2> a = Snake<2>::from_template(s, s.positions), b = a;
    const double cholesky = solve(a, s, LinearSolver::kSparseNormalCholesky), schur = solve(b, s, LinearSolver::kSparseSchur);
    std::printf("region global from r = %.1f: mean offset %.3f (sparse Schur %.3f)\n", start, cholesky, schur);
    EXPECT_LT(cholesky, 0.7 * (start - 10.0));
    EXPECT_GT(cholesky, 0.0);
    EXPECT_NEAR(schur, cholesky, 1e-3);
  }
}

}  // namespace
}  // namespace dsnake
