// How the 3D stages keep their edits from crossing the surface (remesh/pass.h, EditChecking):
// optimistic checking gives the mesh that checking every edit gives; a crossing found after a
// stage sends it back to checking every edit; and the check after the stage answers as the
// brute-force pair tests do.
#include "framework/metrics/metrics.h"
#include "remesh/delaunay.h"
#include "framework/mesh/edit_mesh.h"
#include "remesh/pass.h"
#include "remesh/refine.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <memory>
#include <numbers>
#include <random>
#include <string>

namespace dsnake {
namespace {


std::vector<std::unique_ptr<Remesher<3>>> pipeline(double edge, EditChecking checking) {
  std::vector<std::unique_ptr<Remesher<3>>> p;
  p.push_back(std::make_unique<RefineRemesher>(RefineOptions{0.8 * edge, 0, 0.5}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kFlips, 30, true, 25}));
  p.push_back(std::make_unique<UniformRemesher>(UniformOptions{2, 45}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kPlanar, 30, true, 25}));
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

// The test surfaces (sphere, torus, genus 2, star) with free vertices and their typical edge
// lengths; `fine`: denser versions.
struct Surface {
  std::string name;
  Snake<3> snake;
  double edge;
};
std::vector<Surface> surfaces(bool fine) {
  using test::with_free_vertices;
  return {{"sphere", with_free_vertices(test::icosphere(fine ? 3 : 2, 5.0), 3), fine ? 0.9 : 1.7},
          {"torus", with_free_vertices(fine ? test::torus(40, 16) : test::torus(24, 10), 2), fine ? 0.5 : 0.8},
          {"genus2", with_free_vertices(test::two_hole_slab(fine ? 3 : 2), 2), fine ? 0.5 : 1.0},
          {"star", with_free_vertices(test::star_sphere(3), 3), 0.12}};
}

// Whether a live triangle in slot `first` or later conflicts with the rest, by the brute-force
// pair tests.
bool conflicts_by_brute_force(const EditMesh& m, int first) {
  for (int f = first; f < m.num_triangle_slots(); ++f) {
    const int self[1] = {f};
    if (m.tri_alive(f) && m.intersects_any_brute_force(std::span<const Triangle>(&m.tri(f), 1), self)) return true;
  }
  return false;
}

TEST(OptimisticChecking, SameMeshAsCheckingEveryEdit) {
  for (const auto& c : surfaces(false)) {
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
    stages.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kFlips, 30, false, 25}));
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
    try_flip(m, moved[0], ring[0], -1.0);
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

// One vertex of a small sphere thrown about, its ring jittered: folds and crossings inside the
// fan (pairs sharing a vertex, which the check clears fan by fan) and clean moves; the check
// agrees with brute force on every one.
TEST(OptimisticChecking, FanByFanAgreesWithBruteForce) {
  const Snake<3> sphere = test::icosphere(1, 1.0);
  int conflicts = 0, clean = 0;
  for (int trial = 0; trial < 400; ++trial) {
    EditMesh m(sphere);
    std::mt19937 rng(7 + trial);
    std::uniform_real_distribution<double> unit(-1, 1);
    const int v = trial % m.num_vertices();
    std::vector<int> ring;
    m.ring(v, ring);
    const double size = 0.1 + 1.9 * (trial % 5) / 4.0;  // the ring's radius is about 0.6
    m.begin_optimistic();
    // Along the sphere (its normal is the position), past the ring for the large ones.
    const Point<3> n = m.pos(v).normalized();
    Point<3> along(unit(rng), unit(rng), unit(rng));
    along = (along - along.dot(n) * n).normalized();
    m.move_vertex(v, m.pos(v) + size * along + 0.1 * unit(rng) * n);
    for (int w : ring) m.move_vertex(w, m.pos(w) + 0.05 * Point<3>(unit(rng), unit(rng), unit(rng)));
    const bool verified = m.end_optimistic(true);
    const bool brute = conflicts_by_brute_force(m, 0);
    EXPECT_EQ(verified, !brute) << "trial " << trial;
    (brute ? conflicts : clean)++;
  }
  EXPECT_GT(conflicts, 40);
  EXPECT_GT(clean, 40);
}

// A hexagonal bipyramid: apex v over the ring r0..r5, apex w under it.
EditMesh bipyramid(const PointList<3>& p) {
  std::vector<Triangle> t;
  for (int i = 0; i < 6; ++i) t.push_back({0, 1 + i, 1 + (i + 1) % 6}), t.push_back({7, 1 + (i + 1) % 6, 1 + i});
  std::vector<int> ids(8, -1);
  return EditMesh(Snake<3>(p, Connectivity::mesh(8, std::move(t)), std::move(ids)));
}

// Whether two triangles of v's fan conflict, by the pair tests themselves.
bool fan_conflicts(const EditMesh& m, int v) {
  for (const auto& c : m.corners(v)) {
    const int self[1] = {c.f};
    std::vector<int> others;
    for (const auto& d : m.corners(v))
      if (d.f != c.f) others.push_back(d.f);
    // Brute force against the fan only: everything outside it is ignored.
    std::vector<int> ignore = {c.f};
    for (int f = 0; f < m.num_triangle_slots(); ++f)
      if (std::find(others.begin(), others.end(), f) == others.end() && f != c.f) ignore.push_back(f);
    if (m.intersects_any_brute_force(std::span<const Triangle>(&m.tri(c.f), 1), ignore)) return true;
    (void)self;
  }
  return false;
}

// Fans that must not be cleared, each by one of the three conditions. A fold the projection
// cannot see: the two triangles at edge v-r1 stand almost upright and
// close to 2 degrees, and both turn counter-clockwise seen from above. Only the 80-degree
// cone on the normals keeps the fan from being cleared.
TEST(FanIsEmbedded, FoldsDoubleWindingsAndSliversAreNotCleared) {
  PointList<3> p = {{0, 0, 0}};
  const double angle[6] = {-0.02, 0, 0.02, 2.1, 3.1, 4.2};  // ring directions, radians
  for (int i = 0; i < 6; ++i) p.push_back({std::cos(angle[i]), std::sin(angle[i]), 0});
  p[1] = {0.5, -0.02, 1}, p[3] = {0.5, 0.02, 1};  // r0 and r2 above the edge v-r1
  p.push_back({0, 0, -3});
  const EditMesh m = bipyramid(p);
  EXPECT_TRUE(fan_conflicts(m, 0));
  EXPECT_FALSE(m.fan_is_embedded(0));
  // The same ring flat: cleared, and indeed nothing conflicts.
  PointList<3> flat = {{0, 0, 0}};
  for (int i = 0; i < 6; ++i) flat.push_back({std::cos(i * std::numbers::pi / 3), std::sin(i * std::numbers::pi / 3), 0.1});
  flat.push_back({0, 0, -3});
  const EditMesh ok = bipyramid(flat);
  EXPECT_TRUE(ok.fan_is_embedded(0));
  EXPECT_FALSE(fan_conflicts(ok, 0));
  // A ring that winds twice around v (each step a counter-clockwise turn of 120 degrees).
  PointList<3> twice = {{0, 0, 0}};
  for (int i = 0; i < 6; ++i)
    twice.push_back({std::cos(i * 2 * std::numbers::pi / 3) * (1 + 0.1 * i), std::sin(i * 2 * std::numbers::pi / 3) * (1 + 0.1 * i), 0.1});
  twice.push_back({0, 0, -3});
  const EditMesh wound = bipyramid(twice);
  EXPECT_TRUE(fan_conflicts(wound, 0));
  EXPECT_FALSE(wound.fan_is_embedded(0));
  // A sliver at v: r2 1e-13 radians past r1, so that the triangles on either side of it touch
  // within the pair tests' tolerance. Only the margin on each turn keeps it from being cleared.
  PointList<3> sliver = {{0, 0, 0}};
  for (double a : {-1.0, 0.0, 1e-13, 2.0, 3.1, 4.2}) sliver.push_back({std::cos(a), std::sin(a), 0.1});
  sliver.push_back({0, 0, -3});
  const EditMesh thin = bipyramid(sliver);
  EXPECT_TRUE(fan_conflicts(thin, 0));
  EXPECT_FALSE(thin.fan_is_embedded(0));
}

// Random fans of the bipyramid, some steep, some folded, some fine: a cleared fan never holds
// a conflicting pair.
TEST(FanIsEmbedded, AClearedFanNeverHoldsAConflict) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(-1, 1);
  int cleared = 0, conflicting = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double lift = 0.2 + 2.5 * (trial % 5) / 4.0, spread = 0.6 * (trial % 4);
    PointList<3> p = {{0, 0, 0}};
    for (int i = 0; i < 6; ++i) {
      const double a = i * std::numbers::pi / 3 + spread * unit(rng);
      p.push_back({std::cos(a) * (1 + 0.5 * unit(rng)), std::sin(a) * (1 + 0.5 * unit(rng)), lift * unit(rng)});
    }
    p.push_back({0, 0, -3});
    const EditMesh m = bipyramid(p);
    const bool embedded = m.fan_is_embedded(0), conflicts = fan_conflicts(m, 0);
    EXPECT_FALSE(embedded && conflicts) << "trial " << trial;
    cleared += embedded;
    conflicting += conflicts;
  }
  EXPECT_GT(cleared, 200);
  EXPECT_GT(conflicting, 50);
}

// A small fine sphere moved rigidly through a coarse icosahedron (every fan stays as it was):
// the crossings are all between triangles that share no vertex, a small one against a face
// many grid cells wide, and the grid part of the check finds them as brute force does.
TEST(OptimisticChecking, CrossingsBetweenFarTrianglesAgreeWithBruteForce) {
  const Snake<3> big = test::icosphere(0, 1.0), small = test::icosphere(2, 0.3);
  const int nb = big.num_vertices(), ns = small.num_vertices();
  std::vector<Triangle> tris = big.connectivity().triangles();
  const int big_faces = static_cast<int>(tris.size());
  for (const auto& t : small.connectivity().triangles()) tris.push_back({t[0] + nb, t[1] + nb, t[2] + nb});
  PointList<3> p = big.positions();
  for (int v = 0; v < ns; ++v) p.push_back(small.positions()[v] + Point<3>(5, 0, 0));
  const Snake<3> both(p, Connectivity::mesh(nb + ns, std::move(tris)), std::vector<int>(nb + ns, -1));
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(-1, 1);
  int conflicts = 0, clean = 0;
  for (int trial = 0; trial < 80; ++trial) {
    EditMesh m(both);
    // The small sphere's centre 0.3 to 1.3 from the icosahedron's, in a random direction (the
    // icosahedron's faces are 0.79 to 1 from its centre).
    Point<3> dir(unit(rng), unit(rng), unit(rng));
    dir.normalize();
    const Point<3> shift = (0.3 + 1.0 * (trial % 11) / 10.0) * dir - Point<3>(5, 0, 0);
    m.begin_optimistic();
    for (int v = nb; v < nb + ns; ++v) m.move_vertex(v, m.pos(v) + shift);
    const bool verified = m.end_optimistic(true);
    const bool brute = conflicts_by_brute_force(m, big_faces);
    EXPECT_EQ(verified, !brute) << "trial " << trial;
    (brute ? conflicts : clean)++;
  }
  EXPECT_GT(conflicts, 10);
  EXPECT_GT(clean, 10);
}

// The sweeps that reuse refusals (valence flips, simplify) give the mesh, and the reports,
// that evaluating every candidate in every sweep gives.
TEST(ReusedRefusals, SameMeshAndReportsAsEvaluatingEveryCandidate) {
  for (const auto& c : surfaces(true)) {
    SCOPED_TRACE(c.name);
    auto stages = [&](bool reuse) {
      std::vector<std::unique_ptr<Remesher<3>>> p;
      p.push_back(std::make_unique<RefineRemesher>(RefineOptions{0.9 * c.edge, 0, 0.5}));
      auto flips = std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kFlips, 30, true, 25});
      flips->set_reuse_refusals(reuse);
      p.push_back(std::move(flips));
      p.push_back(std::make_unique<UniformRemesher>(UniformOptions{1, 45}));
      auto simplify = std::make_unique<SimplifyRemesher>(SimplifyOptions{0.5 * c.edge, 1.2 * c.edge, 0.2, 45});
      simplify->set_reuse_refusals(reuse);
      p.push_back(std::move(simplify));
      return p;
    };
    Snake<3> reused = c.snake, evaluated = c.snake;
    auto with = stages(true), without = stages(false);
    for (int pass = 0; pass < 3; ++pass) {
      const auto r1 = apply_pass(with, reused, {}), r2 = apply_pass(without, evaluated, {});
      for (size_t i = 0; i < r1.size(); ++i) {
        EXPECT_EQ(r1[i].rejected_edits, r2[i].rejected_edits) << "pass " << pass << " stage " << i;
        EXPECT_EQ(r1[i].vertices_after, r2[i].vertices_after) << "pass " << pass << " stage " << i;
      }
    }
    EXPECT_NE(reused.num_vertices(), c.snake.num_vertices());
    expect_same(reused, evaluated);
  }
}

// On a mesh large enough for the check to run on two threads: the same answers as on one, for
// a clean move, a fold (a pair sharing a vertex) and a crossing of far triangles.
TEST(OptimisticChecking, SameAnswerOnOneAndTwoThreads) {
  const Snake<3> sphere = test::icosphere(5, 1.0);  // 10242 vertices, 20480 triangles
  const int saved = omp_get_max_threads();
  for (int threads : {1, 2}) {
    SCOPED_TRACE(threads);
    omp_set_num_threads(threads);
    auto check = [&](const std::vector<std::pair<int, Point<3>>>& moves) {
      EditMesh m(sphere);
      m.begin_optimistic();
      for (const auto& [v, p] : moves) m.move_vertex(v, p);
      return m.end_optimistic(true);
    };
    const Point<3> x = sphere.positions()[5000];
    const Point<3> along = x.cross(Point<3>(0, 0, 1)).normalized();  // the edges are about 0.03
    EXPECT_TRUE(check({{5000, 1.001 * x}}));                 // a small bump: clean
    EXPECT_FALSE(check({{5000, x + 0.1 * along}}));          // past its ring: folds onto its neighbours
    EXPECT_FALSE(check({{5000, -1.01 * x}}));                // through the sphere: pokes out of the far side
    EXPECT_TRUE(check({{5000, -0.99 * x}}));                 // a needle to just short of the far side
  }
  omp_set_num_threads(saved);
}

}  // namespace
}  // namespace dsnake
