// RemeshPipeline<D> (remesh/pipeline.h) is the remeshing of a phase as one Remesher: in 3D the
// very same snake and reports as apply_pass over its stages (itself tested against the stages
// one by one in pass_test.cpp), also with a stage that is not an edit stage in the middle; in
// 2D the same as each stage's apply() in turn. apply() sums the reports.
#include "remesh/pipeline.h"

#include "remesh/delaunay.h"
#include "remesh/pass.h"
#include "remesh/refine.h"
#include "remesh/resample.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>

namespace dsnake {
namespace {

// A remesher that is not an edit stage: moves every free vertex a little towards the origin
// (positions only), so that a pipeline must split its run of edit stages around it.
class ShrinkFree final : public Remesher<3> {
 public:
  std::string type() const override { return "shrink_free"; }
  RemeshReport apply(Snake<3>& snake, const RemeshContext<3>&) override {
    auto& q = snake.positions();
    for (int v = 0; v < snake.num_vertices(); ++v)
      if (!snake.is_deformation_vertex(v)) q[v] *= 0.999;
    return {type(), snake.num_vertices(), snake.num_vertices(), 0};
  }
};

Snake<3> jittered_torus(unsigned seed) {
  const Snake<3> t = test::torus(48, 20, 3.0, 1.0);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> j(-0.03, 0.03);
  PointList<3> p = t.positions();
  for (auto& x : p) x += Point<3>(j(rng), j(rng), j(rng));
  std::vector<int> ids = t.template_ids();
  for (size_t v = 0; v < ids.size(); ++v)
    if (v % 4 != 0) ids[v] = -1;
  return Snake<3>(std::move(p), t.connectivity(), std::move(ids));
}

std::vector<std::unique_ptr<Remesher<3>>> stages_3d(double edge, bool with_other) {
  std::vector<std::unique_ptr<Remesher<3>>> p;
  p.push_back(std::make_unique<RefineRemesher>(RefineOptions{1.3 * edge, 0, 0.5}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kFlips, 30, true, 25}));
  if (with_other) p.push_back(std::make_unique<ShrinkFree>());
  p.push_back(std::make_unique<UniformRemesher>(UniformOptions{2, 45}));
  p.push_back(std::make_unique<SimplifyRemesher>(SimplifyOptions{0.5 * edge, edge, 0.1, 45}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kPlanar, 30, true, 25}));
  return p;
}

void expect_same_reports(const std::vector<RemeshReport>& got, const std::vector<RemeshReport>& expected) {
  ASSERT_EQ(got.size(), expected.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].stage, expected[i].stage) << i;
    EXPECT_EQ(got[i].vertices_before, expected[i].vertices_before) << i;
    EXPECT_EQ(got[i].vertices_after, expected[i].vertices_after) << i;
    EXPECT_EQ(got[i].rejected_edits, expected[i].rejected_edits) << i;
  }
}

template <int D>
void expect_same_snake(const Snake<D>& got, const Snake<D>& expected) {
  ASSERT_EQ(got.num_vertices(), expected.num_vertices());
  EXPECT_EQ(got.positions(), expected.positions());  // bit-identical
  EXPECT_EQ(got.template_ids(), expected.template_ids());
  EXPECT_EQ(got.connectivity().triangles(), expected.connectivity().triangles());
}

TEST(RemeshPipeline3, SameSnakeAndReportsAsApplyPass) {
  struct Case {
    const char* name;
    Snake<3> snake;
    double edge;
  };
  std::vector<Case> cases;
  cases.push_back({"torus", jittered_torus(1), 0.3});
  cases.push_back({"star", test::with_free_vertices(test::star_sphere(3), 3), 0.12});
  cases.push_back({"genus2", test::with_free_vertices(test::two_hole_slab(2), 2), 1.0});
  for (auto& c : cases) {
    for (const bool with_other : {false, true}) {
      SCOPED_TRACE(std::string(c.name) + (with_other ? " with a non-edit stage" : ""));
      Snake<3> through_pass = c.snake, through_pipeline = c.snake;
      auto stages = stages_3d(c.edge, with_other);
      RemeshPipeline<3> pipeline(stages_3d(c.edge, with_other));
      ASSERT_EQ(pipeline.stages().size(), stages.size());
      for (size_t i = 0; i < stages.size(); ++i) EXPECT_EQ(pipeline.stages()[i]->type(), stages[i]->type());
      for (int pass = 0; pass < 2; ++pass) {
        const auto expected = apply_pass(stages, through_pass, {});
        expect_same_reports(pipeline.apply_all(through_pipeline, {}), expected);
      }
      EXPECT_NE(through_pass.num_vertices(), c.snake.num_vertices());  // the stages did change the mesh
      expect_same_snake(through_pipeline, through_pass);
      EXPECT_EQ(through_pipeline.connectivity().closed_manifold_problem(), "");
    }
  }
}

TEST(RemeshPipeline3, ApplySumsTheStagesReports) {
  Snake<3> a = jittered_torus(2), b = a;
  RemeshPipeline<3> one(stages_3d(0.3, true)), two(stages_3d(0.3, true));
  const int before = a.num_vertices();
  const auto reports = one.apply_all(a, {});
  const RemeshReport total = two.apply(b, {});
  EXPECT_EQ(two.type(), "pipeline");
  EXPECT_EQ(total.stage, "pipeline");
  EXPECT_EQ(total.vertices_before, before);
  EXPECT_EQ(total.vertices_after, reports.back().vertices_after);
  int rejected = 0;
  for (const auto& r : reports) rejected += r.rejected_edits;
  EXPECT_EQ(total.rejected_edits, rejected);
  expect_same_snake(b, a);
}

TEST(RemeshPipeline3, AnEmptyPipelineChangesNothing) {
  Snake<3> s = jittered_torus(3);
  const Snake<3> before = s;
  RemeshPipeline<3> pipeline({});
  EXPECT_TRUE(pipeline.apply_all(s, {}).empty());
  const RemeshReport r = pipeline.apply(s, {});
  EXPECT_EQ(r.vertices_before, before.num_vertices());
  EXPECT_EQ(r.vertices_after, before.num_vertices());
  EXPECT_EQ(s.topology_version(), before.topology_version());
  expect_same_snake(s, before);
}

std::vector<std::unique_ptr<Remesher<2>>> stages_2d() {
  std::vector<std::unique_ptr<Remesher<2>>> p;
  p.push_back(std::make_unique<ResampleRemesher>(ResampleOptions{0.5, 2.0}));
  p.push_back(std::make_unique<ResampleRemesher>(ResampleOptions{1.0, 3.0}));
  p.push_back(std::make_unique<ResampleRemesher>(ResampleOptions{0.3, 1.0}));
  return p;
}

TEST(RemeshPipeline2, SameSnakeAndReportsAsEachStageInTurn) {
  const Snake<2> base = test::uneven_ellipse(40);
  Snake<2> one_by_one = base, through_pipeline = base;
  auto stages = stages_2d();
  RemeshPipeline<2> pipeline(stages_2d());
  ASSERT_EQ(pipeline.stages().size(), 3u);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<RemeshReport> expected;
    for (auto& r : stages) expected.push_back(r->apply(one_by_one, {}));
    expect_same_reports(pipeline.apply_all(through_pipeline, {}), expected);
  }
  EXPECT_NE(one_by_one.num_vertices(), base.num_vertices());
  expect_same_snake(through_pipeline, one_by_one);
  EXPECT_TRUE(through_pipeline.connectivity().is_polygon());
}

}  // namespace
}  // namespace dsnake
