// The safety checks behind every 3D stage: EditMesh::intersects (crossing, piercing at a
// shared vertex, folding at a shared edge) and the closed-manifold guard.
#include "remesh/mesh_edit.h"

#include "tests/remesh/test_meshes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace dsnake {
namespace {

using remesh_detail::EditMesh;

TEST(EditMesh, DetectsTrianglesThatCrossOrFoldOntoTheSurface) {
  EditMesh m(test::icosphere(1, 1.0));
  // A triangle from the centre to well outside crosses the sphere.
  const int a = m.add_vertex({0, 0, 0}), b = m.add_vertex({2, 0.1, 0}), c = m.add_vertex({2, -0.1, 0.1});
  EXPECT_TRUE(m.intersects({a, b, c}, {}));
  // A small triangle far outside touches nothing.
  const int d = m.add_vertex({3, 3, 3}), e = m.add_vertex({3.1, 3, 3}), f = m.add_vertex({3, 3.1, 3});
  EXPECT_FALSE(m.intersects({d, e, f}, {}));
  // A triangle on an existing vertex whose opposite edge pierces the surface: caught through
  // the shared-vertex test.
  const int g = m.add_vertex(1.5 * m.pos(0) - 1.2 * m.pos(0).normalized().cross(Point<3>(0, 0, 1)).normalized());
  const int h = m.add_vertex(-0.3 * m.pos(0));
  EXPECT_TRUE(m.intersects({0, g, h}, {}));
  // An existing triangle duplicated (shared edge and vertex) is a fold; ignoring the original
  // it is fine.
  const Triangle t = m.tri(0);
  EXPECT_TRUE(m.intersects(t, {}));
  const int self[1] = {0};
  EXPECT_FALSE(m.intersects(t, self));
  // The same triangle with its third vertex pulled back onto its neighbour's side folds.
  const int f2 = m.face_with_edge(t[1], t[0]);
  const int o = m.opposite(f2, t[1], t[0]);
  const int fold = m.add_vertex(0.999 * m.pos(o) + 0.0005 * (m.pos(t[0]) + m.pos(t[1])));
  const int ignore[1] = {0};
  EXPECT_TRUE(m.intersects({t[0], t[1], fold}, ignore));
}

TEST(EditMesh, RingsAreCounterClockwiseAndFlipsKeepTheMeshClosed) {
  Snake<3> s = test::icosphere(1, 1.0);
  EditMesh m(s);
  std::vector<int> ring;
  m.ring(0, ring);
  ASSERT_EQ(ring.size(), 5u);
  // Counter-clockwise seen from outside: (r_i - v) x (r_i+1 - v) points outward.
  for (size_t i = 0; i < ring.size(); ++i)
    EXPECT_GT((m.pos(ring[i]) - m.pos(0)).cross(m.pos(ring[(i + 1) % 5]) - m.pos(0)).dot(m.pos(0)), 0);
  // Flipping an edge of the (convex) sphere makes a dent whose new edge bends by 42.6 degrees
  // (the old one by 22.5): refused under a 40-degree limit, done under 60, and the result
  // stays closed with the same Euler characteristic.
  EXPECT_EQ(remesh_detail::try_flip(m, 0, ring[0], std::cos(40 * std::numbers::pi / 180)),
            remesh_detail::FlipResult::kRejected);
  const auto r = remesh_detail::try_flip(m, 0, ring[0], std::cos(60 * std::numbers::pi / 180));
  EXPECT_EQ(r, remesh_detail::FlipResult::kFlipped);
  EXPECT_FALSE(m.has_edge(0, ring[0]));
  m.commit(s);
  EXPECT_EQ(s.connectivity().closed_manifold_problem(), "");
  EXPECT_EQ(s.connectivity().euler_characteristic(), 2);
  EXPECT_EQ(s.topology_version(), 1u);
}

}  // namespace
}  // namespace dsnake
