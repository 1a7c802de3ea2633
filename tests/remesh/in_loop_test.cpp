// The remeshing pipeline inside the evolution (§6): the Evolver runs the stages every k
// iterations with a falling refinement threshold; the internal energy learns of each new
// topology through topology_version() (no special case), and every guarantee still holds.
#include "energies/internal.h"
#include "framework/core/evolver.h"
#include "framework/metrics/metrics.h"
#include "remesh/pipeline.h"
#include "remesh/delaunay.h"
#include "remesh/refine.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>

namespace dsnake {
namespace {

TEST(RemeshInLoop, PipelineRunsInsideTheEvolutionAndKeepsItsGuarantees) {
  Snake<3> s = test::icosphere(1, 10.0);
  const Snake<3> start = s;
  Template<3> tmpl{start.positions(), start.connectivity(), {}};
  std::vector<WeightedEnergy<3>> energies;
  energies.push_back({1.0, std::make_unique<InternalEnergy<3>>(InternalOptions{0.05, 0.0, 1.0})});
  EnergyContext<3> context;
  context.tmpl = &tmpl;
  Evolver<3> evolver(context, std::move(energies));
  std::vector<Phase<3>> phases(1);
  phases[0].iterations = 40;
  phases[0].every = 5;
  std::vector<std::unique_ptr<Remesher<3>>> stages;
  stages.push_back(std::make_unique<RefineRemesher>(RefineOptions{1.5, 5.0, 0.5}));
  stages.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{}));
  stages.push_back(std::make_unique<UniformRemesher>(UniformOptions{1, 45}));
  stages.push_back(std::make_unique<SimplifyRemesher>(SimplifyOptions{0.5, 1.0, 0.1, 45}));
  phases[0].remesher = std::make_unique<RemeshPipeline<3>>(std::move(stages));
  const EvolveSummary summary = evolver.run(s, phases);
  EXPECT_NE(summary.status, EvolveStatus::kDiverged);
  EXPECT_GT(s.num_vertices(), 4 * start.num_vertices());  // refined as the threshold fell
  EXPECT_GT(s.topology_version(), 1u);
  EXPECT_EQ(s.connectivity().closed_manifold_problem(), "");
  EXPECT_EQ(s.connectivity().euler_characteristic(), 2);
  EXPECT_EQ(count_self_intersections<3>({s.positions(), s.connectivity()}), 0);
  EXPECT_EQ(s.num_deformation_vertices(), start.num_vertices());
  ASSERT_EQ(summary.phases.size(), 1u);
  EXPECT_EQ(summary.phases[0].remesh_reports.size(), 4u);
}

}  // namespace
}  // namespace dsnake
