// The speed-up of the 3D remeshing pass must not change what it computes: apply_pass (one
// EditMesh for all stages, one write-back) gives the very same snake and vertex counts as
// applying the stages one by one, and the same with 1 and 2 threads. (The mesh-edit kernel's
// own checks are tested in tests/framework/mesh/.)
#include "remesh/delaunay.h"
#include "remesh/pass.h"
#include "remesh/refine.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <memory>
#include <random>

namespace dsnake {
namespace {

// The bench's jittered torus in small: a mid-evolution snake with every 4th vertex a template one.
Snake<3> jittered_torus(int nu, int nv, unsigned seed) {
  Snake<3> t = test::torus(nu, nv, 3.0, 1.0);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> j(-0.03, 0.03);
  PointList<3> p = t.positions();
  for (auto& x : p) x += Point<3>(j(rng), j(rng), j(rng));
  std::vector<int> ids = t.template_ids();
  for (size_t v = 0; v < ids.size(); ++v)
    if (v % 4 != 0) ids[v] = -1;
  return Snake<3>(std::move(p), t.connectivity(), std::move(ids));
}

std::vector<std::unique_ptr<Remesher<3>>> full_pass(double edge) {
  std::vector<std::unique_ptr<Remesher<3>>> p;
  p.push_back(std::make_unique<RefineRemesher>(RefineOptions{1.3 * edge, 0, 0.5}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kFlips, 30, true, 25}));
  p.push_back(std::make_unique<UniformRemesher>(UniformOptions{2, 45}));
  p.push_back(std::make_unique<SimplifyRemesher>(SimplifyOptions{0.5 * edge, edge, 0.1, 45}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kPlanar, 30, true, 25}));
  p.push_back(std::make_unique<UniformRemesher>(UniformOptions{1, 45}));
  return p;
}

TEST(ApplyPass, SameSnakeAsTheStagesOneByOne) {
  struct Case {
    const char* name;
    Snake<3> snake;
    double edge;
  };
  std::vector<Case> cases;
  cases.push_back({"torus", jittered_torus(60, 24, 1), 0.3});
  cases.push_back({"star", test::with_free_vertices(test::star_sphere(3), 3), 0.12});
  cases.push_back({"genus2", test::with_free_vertices(test::two_hole_slab(2), 2), 1.0});
  for (auto& c : cases) {
    SCOPED_TRACE(c.name);
    Snake<3> one_by_one = c.snake, shared = c.snake;
    auto stages = full_pass(c.edge);
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<RemeshReport> expected;
      for (auto& r : stages) expected.push_back(r->apply(one_by_one, {}));
      const auto reports = apply_pass(stages, shared, {});
      ASSERT_EQ(reports.size(), expected.size());
      for (size_t i = 0; i < reports.size(); ++i) {
        EXPECT_EQ(reports[i].stage, expected[i].stage);
        EXPECT_EQ(reports[i].vertices_before, expected[i].vertices_before) << i;
        EXPECT_EQ(reports[i].vertices_after, expected[i].vertices_after) << i;
        EXPECT_EQ(reports[i].rejected_edits, expected[i].rejected_edits) << i;
      }
    }
    EXPECT_NE(one_by_one.num_vertices(), c.snake.num_vertices());  // the pass did change the mesh
    ASSERT_EQ(shared.num_vertices(), one_by_one.num_vertices());
    EXPECT_EQ(shared.positions(), one_by_one.positions());  // bit-identical
    EXPECT_EQ(shared.template_ids(), one_by_one.template_ids());
    EXPECT_EQ(shared.connectivity().triangles(), one_by_one.connectivity().triangles());
    EXPECT_EQ(shared.connectivity().closed_manifold_problem(), "");
  }
}

// The parallel part (uniform's proposals, from the positions at the start of a sweep) only
// reads the mesh and is gathered in vertex order: a pass gives the same snake with 1 and 2
// threads.
TEST(ApplyPass, SameSnakeWithOneAndTwoThreads) {
  const Snake<3> base = jittered_torus(60, 24, 2);
  Snake<3> one = base, two = base;
  auto stages = full_pass(0.3);
  omp_set_num_threads(1);
  apply_pass(stages, one, {});
  omp_set_num_threads(2);
  apply_pass(stages, two, {});
  EXPECT_NE(one.num_vertices(), base.num_vertices());
  EXPECT_EQ(one.positions(), two.positions());
  EXPECT_EQ(one.connectivity().triangles(), two.connectivity().triangles());
}

}  // namespace
}  // namespace dsnake
