// The registration as one call (registration/registration.h), on a phantom built here: a circle
// template placed off-centre and scaled, registered to a blurred bright disk of known radius.
// No experiment file, no output folder: the test program links the registration library alone.
#include "registration/registration.h"

#include "docs/examples/register_circle.h"
#include "energies/asap_mls.h"
#include "energies/external.h"
#include "energies/internal.h"
#include "energies/landmarks.h"
#include "fields/gvf.h"
#include "framework/core/errors.h"
#include "tests/energies/edge_images.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

namespace dsnake {
namespace {

using test_support::blurred_edge_radius;
using test_support::bright_disk;
using test_support::radial_error;
using test_support::radial_image;
using test_support::round_template;

constexpr double kDiskRadius = 20.0;  // mm
constexpr double kBlur = 1.5;         // mm, the image's
constexpr double kEdgeSigma = 1.0;    // mm, the GVF edge map's (GvfFieldOptions' default)

// A 72 x 72 image of 1 mm voxels about the origin: the disk of radius 20 mm, blurred.
Image<2> disk_image() { return radial_image<2>(72, 1.0, bright_disk(kDiskRadius), kBlur); }

// Where the registered circle should lie: the blurred disk's edge, as the edge map sees it.
double edge_radius() {
  return blurred_edge_radius(2, kDiskRadius, std::sqrt(kBlur * kBlur + kEdgeSigma * kEdgeSigma));
}

// A 48-vertex circle of radius 10 about the origin (the rest shape), with one landmark.
Template<2> circle_template() {
  Template<2> t = round_template<2>(10.0, Point<2>::Zero(), 48);
  t.landmarks["east"] = 0;
  return t;
}

// The template scaled by 1.4 and moved by (3, -2): inside the disk and off its centre.
PointList<2> placed(const Template<2>& t) {
  PointList<2> q;
  for (const auto& p : t.positions) q.push_back(1.4 * p + Point<2>(3, -2));
  return q;
}

// Internal + external (GVF) + ASAP-MLS, one phase (docs/examples/register_circle.cpp); the caller
// adds phases or changes the solver.
RegistrationProblem<2> disk_problem(const Template<2>& t, const Image<2>& image) {
  return circle_problem(t, placed(t), image);
}

// Every vertex lies on the disk's edge within `tolerance` mm.
void expect_on_edge(const Snake<2>& snake, double tolerance) {
  const auto [mean, worst] = radial_error(snake, edge_radius());
  EXPECT_LT(worst, tolerance) << "mean " << mean;
}

TEST(RegisterTemplate, TheCircleLandsOnTheDiskAndTheResultSaysHow) {
  const Image<2> image = disk_image();
  const Template<2> t = circle_template();
  const double start_worst = radial_error(Snake<2>::from_template(t, placed(t)), edge_radius()).second;
  ASSERT_GT(start_worst, 9.0);  // the placed circle is 2.3 to 9.5 mm off the edge

  const RegistrationResult<2> r = register_template(disk_problem(t, image));
  expect_on_edge(r.snake, 0.3);

  EXPECT_EQ(r.summary.status, EvolveStatus::kConverged);
  ASSERT_EQ(r.summary.phases.size(), 1u);
  EXPECT_GT(r.summary.iterations, 0);
  EXPECT_LT(r.summary.iterations, 400);
  EXPECT_EQ(r.summary.phases[0].iterations, r.summary.iterations);
  EXPECT_EQ(r.term_names, (std::vector<std::string>{"internal", "external", "asap_mls"}));
  // No remeshing: the snake is the template's vertices, in order.
  EXPECT_EQ(r.initial_vertices, 48);
  ASSERT_EQ(r.snake.num_vertices(), 48);
  std::vector<int> ids(48);
  std::iota(ids.begin(), ids.end(), 0);
  EXPECT_EQ(r.snake.template_ids(), ids);
  // The field on the placed template's box (radius 14 about (3, -2)) widened by 20 mm, inside
  // the 72 x 72 image.
  EXPECT_GT(r.field_region.num_voxels(), 0);
  EXPECT_LT(r.field_region.num_voxels(), image.num_voxels());
  EXPECT_GT(r.force.max, 0.0);
  EXPECT_GT(r.force.median_start, 0.0);
  EXPECT_TRUE(r.global_solves.empty());
  EXPECT_TRUE(r.landmarks.empty());
  EXPECT_TRUE(r.guarded);  // the snake iteration, the collision guard on by default
  EXPECT_GE(r.timings.field_s, 0.0);
  EXPECT_GE(r.timings.evolve_s, 0.0);
  EXPECT_EQ(r.timings.potential_s, 0.0);
}

TEST(RegisterTemplate, TheWholeImageRegionComputesTheFieldEverywhere) {
  const Image<2> image = disk_image();
  const Template<2> t = circle_template();
  RegistrationProblem<2> problem = disk_problem(t, image);
  problem.field_region.extent = RegionExtent::kWhole;
  const RegistrationResult<2> r = register_template(std::move(problem));
  EXPECT_EQ(r.field_region.num_voxels(), image.num_voxels());
  expect_on_edge(r.snake, 0.3);
}

// Records what the driver reports.
class Recorder : public EvolverObserver<2> {
 public:
  void on_iteration(const IterationInfo& info, const Snake<2>& snake) override {
    iterations.push_back(info);
    vertices_seen &= snake.num_vertices() == info.vertices;
  }
  void on_phase_end(int phase, const PhaseSummary& summary, const Snake<2>&) override {
    phase_ends.emplace_back(phase, summary.iterations);
  }
  std::vector<IterationInfo> iterations;
  std::vector<std::pair<int, int>> phase_ends;  // phase, its iterations
  bool vertices_seen = true;
};

TEST(RegisterTemplate, ObserversHearEveryIterationAndPhaseEnd) {
  const Image<2> image = disk_image();
  const Template<2> t = circle_template();
  RegistrationProblem<2> problem = disk_problem(t, image);
  // A second phase with ASAP switched off (its phase weight 0) and a small budget.
  Phase<2>& last = problem.phases.emplace_back();
  last.iterations = 5;
  last.weights = {1.0, 1.0, 0.0};
  Recorder first, second;
  std::vector<std::string> messages;
  const RegistrationResult<2> r = register_template(std::move(problem), {&first, &second},
                                                    [&](const std::string& m) { messages.push_back(m); });
  EXPECT_EQ(messages, std::vector<std::string>{"computing the gvf field on the image"});
  ASSERT_EQ(r.summary.phases.size(), 2u);
  EXPECT_EQ(r.summary.phases[1].iterations, 5);
  for (const Recorder* rec : {&first, &second}) {
    ASSERT_EQ(int(rec->iterations.size()), r.summary.iterations);
    for (size_t k = 0; k < rec->iterations.size(); ++k) {
      const IterationInfo& info = rec->iterations[k];
      EXPECT_EQ(info.iteration, int(k) + 1);
      const int phase0 = r.summary.phases[0].iterations;
      EXPECT_EQ(info.phase, int(k) < phase0 ? 0 : 1);
      EXPECT_EQ(info.phase_iteration, int(k) < phase0 ? int(k) + 1 : int(k) - phase0 + 1);
      ASSERT_EQ(info.energy_terms.size(), 3u);
      if (info.phase == 1) {
        EXPECT_EQ(info.energy_terms[2], 0.0);  // switched off
      }
    }
    EXPECT_TRUE(rec->vertices_seen);
    EXPECT_EQ(rec->phase_ends, (std::vector<std::pair<int, int>>{{0, r.summary.phases[0].iterations}, {1, 5}}));
  }
  expect_on_edge(r.snake, 0.3);
}

TEST(RegisterTemplate, TheGlobalSolveReportsEverySolve) {
  const Image<2> image = disk_image();
  const Template<2> t = circle_template();
  RegistrationProblem<2> problem = disk_problem(t, image);
  problem.solver = SolverKind::kGlobal;
  problem.potential = PotentialOptions{};  // the least-squares integral of the GVF field
  const RegistrationResult<2> r = register_template(std::move(problem));
  ASSERT_EQ(r.global_solves.size(), 1u);
  EXPECT_FALSE(r.guarded);  // the global solve has no move to guard
  ASSERT_FALSE(r.global_solves[0].empty());
  for (const GlobalSolveSummary& s : r.global_solves[0]) {
    EXPECT_GT(s.iterations, 0);
    EXPECT_LT(s.final_cost, s.initial_cost);
  }
  EXPECT_GE(r.timings.potential_s, 0.0);
  expect_on_edge(r.snake, 1.0);  // from 2.3 to 9.5 mm off at the start
}

TEST(RegisterTemplate, ALandmarkEnergyReportsItsDistances) {
  const Image<2> image = disk_image();
  const Template<2> t = circle_template();
  RegistrationProblem<2> problem = disk_problem(t, image);
  // "east" (template vertex 0, placed at (3 + 14, -2)) pulled to the edge's point east of the
  // centre; the image's frame is the world's here (an axis-aligned grid).
  const Point<2> target(edge_radius(), 0.0);
  problem.energies.push_back(
      {1.0, std::make_unique<LandmarksEnergy<2>>(LandmarksOptions{.points = {{"east", {target.x(), target.y()}}}})});
  const RegistrationResult<2> r = register_template(std::move(problem));
  ASSERT_EQ(r.landmarks.size(), 1u);
  EXPECT_EQ(r.landmarks[0].energy, 3);
  EXPECT_NEAR(r.landmarks[0].initial_mm.at("east"), (Point<2>(17, -2) - target).norm(), 1e-9);
  EXPECT_LT(r.landmarks[0].final_mm.at("east"), 0.3);
  EXPECT_EQ(r.term_names.back(), "landmarks");
  expect_on_edge(r.snake, 0.3);
}

TEST(RegisterTemplate, AFieldRefusingTheImageNamesTheProblemsSource) {
  const Image<2> image = disk_image();
  const Template<2> t = circle_template();
  RegistrationProblem<2> problem = disk_problem(t, image);
  // An explicit GVF step past the stability bound of 1 mm voxels, 2 / (4 mu (1 + 1)) = 1.25.
  GvfFieldOptions unstable;
  unstable.solve.solver = GvfSolver::kExplicit;
  unstable.solve.time_step = 2.0;
  problem.field = std::make_unique<GvfField<2>>(unstable);
  problem.source = "disk.json";
  try {
    register_template(std::move(problem));
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "disk.json");
    EXPECT_EQ(e.where(), "field.time_step");
  }
}

TEST(RegisterTemplate, TheDocumentationsExampleFindsTheDisk) {
  const Image<2> image = disk_image();
  const Template<2> t = circle_template();
  const RegistrationResult<2> r = register_circle(t, placed(t), image);
  EXPECT_EQ(r.summary.status, EvolveStatus::kConverged);
  expect_on_edge(r.snake, 0.3);
}

}  // namespace
}  // namespace dsnake
