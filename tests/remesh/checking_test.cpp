// How the 3D stages keep their edits from crossing the surface (remesh/pass.h, EditChecking):
// optimistic checking gives the mesh that checking every edit gives; a crossing found after a
// stage sends it back to checking every edit; and the check after the stage answers as the
// brute-force pair tests do.
#include "framework/metrics.h"
#include "remesh/delaunay.h"
#include "remesh/mesh_edit.h"
#include "remesh/pass.h"
#include "remesh/refine.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "tests/remesh/test_meshes.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>

namespace dsnake {
namespace {

using remesh_detail::EditMesh;

std::vector<std::unique_ptr<Remesher<3>>> pipeline(double edge, EditChecking checking) {
  std::vector<std::unique_ptr<Remesher<3>>> p;
  p.push_back(std::make_unique<RefineRemesher>(RefineOptions{0.8 * edge, 0, 0.5}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{"flips", 30, true, 25}));
  p.push_back(std::make_unique<UniformRemesher>(UniformOptions{2, 45}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{"planar", 30, true, 25}));
  p.push_back(std::make_unique<SimplifyRemesher>(SimplifyOptions{0.3 * edge, 0.8 * edge, 0.1, 45}));
  for (auto& r : p) static_cast<EditStage&>(*r).set_checking(checking);
  return p;
}

// Two passes of the pipeline under `checking`, stage by stage and through apply_pass.
Snake<3> remeshed(Snake<3> s, double edge, EditChecking checking, bool shared) {
  auto stages = pipeline(edge, checking);
  for (int pass = 0; pass < 2; ++pass) {
    if (shared) {
      apply_pass(stages, s, {});
    } else {
      for (auto& r : stages) r->apply(s, {});
    }
  }
  return s;
}

void expect_same(const Snake<3>& a, const Snake<3>& b) {
  ASSERT_EQ(a.num_vertices(), b.num_vertices());
  EXPECT_EQ(a.positions(), b.positions());  // bit-identical
  EXPECT_EQ(a.template_ids(), b.template_ids());
  EXPECT_EQ(a.connectivity().triangles(), b.connectivity().triangles());
}

TEST(OptimisticChecking, SameMeshAsCheckingEveryEdit) {
  struct Case {
    std::string name;
    Snake<3> snake;
    double edge;
  };
  const std::vector<Case> cases = {{"sphere", test::with_free_vertices(test::icosphere(2, 5.0), 3), 1.7},
                                   {"torus", test::with_free_vertices(test::torus(24, 10), 2), 0.8},
                                   {"genus2", test::with_free_vertices(test::two_hole_slab(2), 2), 1.0},
                                   {"star", test::with_free_vertices(test::star_sphere(3), 3), 0.12}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const Snake<3> every = remeshed(c.snake, c.edge, EditChecking::kEveryEdit, false);
    EXPECT_GT(every.num_vertices(), c.snake.num_vertices());
    expect_same(remeshed(c.snake, c.edge, EditChecking::kOptimistic, false), every);
    expect_same(remeshed(c.snake, c.edge, EditChecking::kOptimistic, true), every);
  }
}

// A sphere of free vertices, jittered along itself, over a copy of it scaled by 1 - gap whose
// vertices are all deformation vertices (never moved), oriented inwards: two sheets gap R
// apart that do not touch. Relaxing the outer sheet moves its vertices into its triangles,
// below the sphere by more than the gap: unchecked, it crosses the inner sheet.
Snake<3> nested_spheres(double gap) {
  const Snake<3> ico = test::icosphere(3, 5.0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> j(-0.12, 0.12);
  PointList<3> p = ico.positions();
  for (auto& x : p) x = (x + Point<3>(j(rng), j(rng), j(rng))).normalized() * 5.0;
  const int n = ico.num_vertices();
  std::vector<Triangle> tris = ico.connectivity().triangles();
  const size_t outer = tris.size();
  for (size_t f = 0; f < outer; ++f) {
    const Triangle& t = tris[f];
    tris.push_back({t[0] + n, t[2] + n, t[1] + n});
  }
  std::vector<int> ids(2 * n, -1);
  for (int v = 0; v < n; ++v) p.push_back(p[v] * (1 - gap)), ids[n + v] = v;
  for (int v = 0; v < n; v += 7) ids[v] = n + v;  // a few deformation vertices on the outer sheet too
  return Snake<3>(std::move(p), Connectivity::mesh(2 * n, std::move(tris)), std::move(ids));
}

TEST(OptimisticChecking, ACrossingAfterTheStageSendsItBackToCheckingEveryEdit) {
  const Snake<3> base = nested_spheres(2e-4);
  ASSERT_EQ(base.connectivity().closed_manifold_problem(), "");
  ASSERT_EQ(count_self_intersections<3>({base.positions(), base.connectivity()}), 0);
  auto run = [&](EditChecking checking) {
    Snake<3> s = base;
    UniformRemesher uniform(UniformOptions{2, 45});
    uniform.set_checking(checking);
    const RemeshReport r = uniform.apply(s, {});
    return std::make_pair(s, r);
  };
  const auto [unchecked, r0] = run(EditChecking::kUnchecked);
  EXPECT_GT(count_self_intersections<3>({unchecked.positions(), unchecked.connectivity()}), 0)
      << "the scene must make relaxation cross the inner sheet";
  const auto [every, r1] = run(EditChecking::kEveryEdit);
  const auto [optimistic, r2] = run(EditChecking::kOptimistic);
  EXPECT_GT(r1.rejected_edits, r0.rejected_edits);  // the crossing moves were rejected
  EXPECT_EQ(count_self_intersections<3>({every.positions(), every.connectivity()}), 0);
  expect_same(optimistic, every);
  EXPECT_EQ(r2.rejected_edits, r1.rejected_edits);
}

// The same through apply_pass, where the run of stages is checked as one: the crossing sends
// the whole run back to checking every edit.
TEST(OptimisticChecking, ACrossingAfterAPassSendsTheWholePassBackToCheckingEveryEdit) {
  const Snake<3> base = nested_spheres(2e-4);
  auto run = [&](EditChecking checking) {
    std::vector<std::unique_ptr<Remesher<3>>> stages;
    stages.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{"flips", 30, false, 25}));
    stages.push_back(std::make_unique<UniformRemesher>(UniformOptions{1, 45}));
    stages.push_back(std::make_unique<UniformRemesher>(UniformOptions{1, 45}));
    for (auto& r : stages) static_cast<EditStage&>(*r).set_checking(checking);
    Snake<3> s = base;
    const auto reports = apply_pass(stages, s, {});
    int rejected = 0;
    for (const auto& r : reports) rejected += r.rejected_edits;
    return std::make_pair(s, rejected);
  };
  const auto [unchecked, r0] = run(EditChecking::kUnchecked);
  EXPECT_GT(count_self_intersections<3>({unchecked.positions(), unchecked.connectivity()}), 0);
  const auto [every, r1] = run(EditChecking::kEveryEdit);
  const auto [optimistic, r2] = run(EditChecking::kOptimistic);
  EXPECT_GT(r1, r0);
  EXPECT_EQ(count_self_intersections<3>({every.positions(), every.connectivity()}), 0);
  expect_same(optimistic, every);
  EXPECT_EQ(r2, r1);
}

// The check after an optimistic run against the brute-force pair tests, on random moves of a
// torus's vertices, small and large (some cross, some do not).
TEST(OptimisticChecking, TheCheckAfterTheStageAgreesWithBruteForce) {
  const Snake<3> torus = test::with_free_vertices(test::torus(30, 12), 1);
  int conflicts = 0, clean = 0;
  for (int trial = 0; trial < 60; ++trial) {
    EditMesh m(torus);
    std::mt19937 rng(100 + trial);
    std::uniform_int_distribution<int> vertex(0, m.num_vertices() - 1);
    const double size = trial % 3 == 0 ? 1.0 : 0.1;
    std::uniform_real_distribution<double> step(-size, size);
    m.begin_optimistic();
    std::vector<int> moved;
    for (int k = 0; k < 5; ++k) {
      const int v = vertex(rng);
      m.move_vertex(v, m.pos(v) + Point<3>(step(rng), step(rng), step(rng)));
      moved.push_back(v);
    }
    // A flip too: new triangles are marked as well.
    const auto ring = [&] {
      std::vector<int> r;
      m.ring(moved[0], r);
      return r;
    }();
    remesh_detail::try_flip(m, moved[0], ring[0], -1.0);
    const bool verified = m.end_optimistic(true);
    bool brute = false;
    for (int f = 0; f < m.num_triangle_slots() && !brute; ++f) {
      if (!m.tri_alive(f)) continue;
      bool marked = false;
      for (int v : m.tri(f)) marked |= std::find(moved.begin(), moved.end(), v) != moved.end();
      marked |= f >= static_cast<int>(torus.connectivity().triangles().size());
      const int self[1] = {f};
      if (marked) brute = m.intersects_any_brute_force(std::span<const Triangle>(&m.tri(f), 1), self);
    }
    EXPECT_EQ(verified, !brute) << "trial " << trial;
    (brute ? conflicts : clean)++;
  }
  EXPECT_GT(conflicts, 5);
  EXPECT_GT(clean, 5);
}

}  // namespace
}  // namespace dsnake
