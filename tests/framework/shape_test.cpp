#include "framework/core/shape.h"

#include "experiments/phantoms/phantoms.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>

namespace dsnake {
namespace {

TEST(Connectivity, IcosphereIsClosedWithOrderedOneRings) {
  const Template<3> ico = make_icosphere(2);
  const Connectivity& c = ico.connectivity;
  EXPECT_EQ(c.closed_manifold_problem(), "");
  EXPECT_EQ(ico.num_vertices(), 162);
  EXPECT_EQ(c.euler_characteristic(), 2);
  // Consecutive one-ring neighbours are themselves adjacent (the ring is a cycle), and the
  // ring turns counter-clockwise about the outward normal.
  for (int v = 0; v < c.num_vertices(); ++v) {
    const auto ring = c.neighbors(v);
    ASSERT_GE(ring.size(), 5u);
    for (size_t k = 0; k < ring.size(); ++k) {
      const int a = ring[k], b = ring[(k + 1) % ring.size()];
      const auto ra = c.neighbors(a);
      EXPECT_NE(std::find(ra.begin(), ra.end(), b), ra.end());
      const Point<3> n = (ico.positions[a] - ico.positions[v]).cross(ico.positions[b] - ico.positions[v]);
      EXPECT_GT(n.dot(ico.positions[v]), 0);  // sphere about the origin: outward = position
    }
  }
}

TEST(Connectivity, OpenAndNonManifoldMeshesAreReported) {
  Template<3> ico = make_icosphere(0);
  auto tris = ico.connectivity.triangles();
  tris.pop_back();
  EXPECT_NE(Connectivity::mesh(12, tris).closed_manifold_problem().find("not closed"), std::string::npos);
  // Two tetrahedra sharing one vertex: closed, but vertex 0 is non-manifold.
  std::vector<Triangle> two = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3},
                               {0, 5, 4}, {0, 4, 6}, {0, 6, 5}, {4, 5, 6}};
  EXPECT_NE(Connectivity::mesh(7, two).closed_manifold_problem().find("vertex 0 is non-manifold"), std::string::npos);
  // A vertex in no triangle.
  EXPECT_NE(Connectivity::mesh(8, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}).closed_manifold_problem().find("vertex 4"),
            std::string::npos);
}

// The first problem in triangle order, with the message naming it: the earliest second
// occurrence of a half-edge, a degenerate triangle if it comes no later, else the missing twin
// of the smallest (a, b).
TEST(Connectivity, ReportsTheFirstProblemByName) {
  const auto ico = make_icosphere(1).connectivity.triangles();
  const int n = 42;
  auto problem = [&](const std::vector<Triangle>& t) { return Connectivity::mesh(n, t).closed_manifold_problem(); };
  EXPECT_EQ(problem(ico), "");
  // A duplicated last triangle: its first half-edge is the earliest second occurrence.
  auto dup = ico;
  dup.push_back(ico.back());
  EXPECT_EQ(problem(dup), "edge (" + std::to_string(ico.back()[0]) + ", " + std::to_string(ico.back()[1]) +
                              ") is shared by more than two triangles or oriented inconsistently");
  // A degenerate triangle before that: reported instead; after a repeat: the repeat is.
  auto degenerate_first = dup;
  degenerate_first.insert(degenerate_first.begin(), Triangle{0, 0, 1});
  EXPECT_EQ(problem(degenerate_first), "triangle 0 is degenerate (repeated vertex)");
  auto repeat_first = ico;
  repeat_first.insert(repeat_first.begin() + 1, ico[0]);
  repeat_first.push_back({3, 4, 3});
  EXPECT_EQ(problem(repeat_first), "edge (" + std::to_string(ico[0][0]) + ", " + std::to_string(ico[0][1]) +
                                       ") is shared by more than two triangles or oriented inconsistently");
  // One triangle flipped: its half-edges now repeat its neighbours' (the earliest at its own
  // position, as the neighbours' come first or later).
  auto flipped = ico;
  std::swap(flipped[5][1], flipped[5][2]);
  EXPECT_NE(problem(flipped).find("is shared by more than two triangles or oriented inconsistently"), std::string::npos);
  // A hole: the twins of the removed triangle's edges are missing; the smallest (a, b) of the
  // half-edges left without a twin is named.
  auto open = ico;
  const Triangle gone = open.back();
  open.pop_back();
  std::array<int, 2> first = {n, n};
  for (int k = 0; k < 3; ++k) first = std::min(first, std::array<int, 2>{gone[(k + 1) % 3], gone[k]});
  EXPECT_EQ(problem(open), "edge (" + std::to_string(std::min(first[0], first[1])) + ", " +
                               std::to_string(std::max(first[0], first[1])) +
                               ") is a boundary edge or oriented inconsistently: the mesh is not closed");
}

TEST(Connectivity, PolygonNeighboursAndEdges) {
  const Connectivity c = Connectivity::polygon(5);
  EXPECT_EQ(c.neighbors(0)[0], 4);
  EXPECT_EQ(c.neighbors(0)[1], 1);
  EXPECT_EQ(c.edges().size(), 5u);
  EXPECT_EQ(c.closed_manifold_problem(), "");
  EXPECT_NE(Connectivity::polygon(2).closed_manifold_problem(), "");
}

TEST(Snake, MeasureAndNormalsFollowOrientation) {
  PointList<2> ccw, cw;
  for (int k = 0; k < 100; ++k) {
    const double a = 2 * M_PI * k / 100;
    ccw.emplace_back(3 + 10 * std::cos(a), 4 + 10 * std::sin(a));
  }
  cw.assign(ccw.rbegin(), ccw.rend());
  for (const auto* pts : {&ccw, &cw}) {
    Template<2> t{*pts, Connectivity::polygon(100), {}};
    const Snake<2> s = Snake<2>::from_template(t, t.positions);
    EXPECT_NEAR(std::abs(s.signed_measure()), 50 * 100 * std::sin(2 * M_PI / 100), 1e-9);
    const auto n = s.vertex_normals();
    for (int v = 0; v < 100; ++v)
      EXPECT_NEAR(n[v].dot((s.positions()[v] - Point<2>(3, 4)).normalized()), 1.0, 1e-9);
  }
  const Template<3> ico = make_icosphere(3);
  const Snake<3> sphere = Snake<3>::from_template(ico, ico.positions);
  // An inscribed polyhedron: slightly below the ball's volume (642 vertices: within 1%).
  EXPECT_LT(sphere.signed_measure(), 4.0 / 3.0 * M_PI);
  EXPECT_GT(sphere.signed_measure(), 0.99 * 4.0 / 3.0 * M_PI);
  const auto n3 = sphere.vertex_normals();
  for (int v = 0; v < sphere.num_vertices(); ++v) EXPECT_NEAR(n3[v].dot(sphere.positions()[v]), 1.0, 1e-3);
}

TEST(Snake, TemplateIdsSurviveSetTopology) {
  const Template<2> t{{{0, 0}, {1, 0}, {1, 1}, {0, 1}}, Connectivity::polygon(4), {{"corner", 2}}};
  Snake<2> s = Snake<2>::from_template(t, t.positions);
  EXPECT_EQ(s.topology_version(), 0u);
  s.set_topology({{0, 0}, {0.5, 0}, {1, 0}, {1, 1}, {0, 1}}, Connectivity::polygon(5), {0, -1, 1, 2, 3});
  EXPECT_EQ(s.topology_version(), 1u);
  EXPECT_EQ(s.vertex_of_template_id(2), 3);
  EXPECT_EQ(s.num_deformation_vertices(), 4);
  EXPECT_FALSE(s.is_deformation_vertex(1));
  EXPECT_EQ(s.vertex_of_template_id(7), -1);
}

TEST(Place, ScalesAndRotatesAboutTheCentroidThenTranslates) {
  const PointList<3> p = {{1, 0, 0}, {-1, 0, 0}, {0, 2, 0}, {0, -2, 0}};
  const auto q = place<3>(p, 2.0, {0, 0, 90}, Point<3>(10, 0, 0));
  EXPECT_NEAR((q[0] - Point<3>(10, 2, 0)).norm(), 0, 1e-12);  // (1,0,0) -> rotate z 90 -> (0,1,0) -> *2 -> +t
  EXPECT_NEAR((q[2] - Point<3>(6, 0, 0)).norm(), 0, 1e-12);
  const auto q2 = place<2>({{0, 0}, {2, 0}}, 1.0, {180}, Point<2>(0, 1));
  EXPECT_NEAR((q2[0] - Point<2>(2, 1)).norm(), 0, 1e-12);
}

}  // namespace
}  // namespace dsnake
