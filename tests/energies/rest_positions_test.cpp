// Rest positions (energies/rest_positions.h): exact at deformation vertices, and at free vertices
// wherever the snake is a similar copy of the template near them (the local fit reproduces a
// similarity, then onto the curved surface the template's vertices sample); the rotation turns
// the snake's frame into the template's.
#include "energies/rest_positions.h"

#include "tests/energies/edge_images.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace dsnake {
namespace {

using namespace test_support;

// An icosphere template (radius 10 mm, edges of about 3.4 mm); the snake is s R p + t with
// triangle 0 split at its centroid by a free vertex. The free vertex's rest position is on the
// sphere beside the template triangle's centroid (the chord point is 0.14 mm inside it; the
// quadric leaves less than 0.03 mm), every deformation vertex's is its template position exactly,
// and each rotation is R^T.
TEST(RestPositions, FreeVertexOfASimilarCopyLandsWhereItWasInserted3D) {
  const Template<3> t = round_template<3>(10.0);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  const double s = 1.3;
  const Point<3> move(2.0, -1.0, 0.5);
  PointList<3> q;
  for (const auto& p : t.positions) q.push_back(s * r * p + move);
  std::vector<int> ids(t.num_vertices());
  for (int i = 0; i < t.num_vertices(); ++i) ids[i] = i;
  std::vector<Triangle> tris = t.connectivity.triangles();
  const Triangle split = tris[0];
  const int f = t.num_vertices();
  const Point<3> centroid = (t.positions[split[0]] + t.positions[split[1]] + t.positions[split[2]]) / 3.0;
  q.push_back(s * r * centroid + move);
  ids.push_back(-1);
  tris[0] = {split[0], split[1], f};
  tris.push_back({split[1], split[2], f});
  tris.push_back({split[2], split[0], f});
  const Snake<3> snake(q, Connectivity::mesh(f + 1, tris), ids);
  const RestPositions<3> rest = rest_positions(t, snake);
  for (int v = 0; v < f; ++v) EXPECT_EQ(rest.positions[v], t.positions[v]);
  EXPECT_GT(10.0 - centroid.norm(), 0.14);
  EXPECT_NEAR(rest.positions[f].norm(), 10.0, 0.03);
  EXPECT_LT((rest.positions[f].normalized() - centroid.normalized()).norm(), 1e-3);
  for (int v = 0; v <= f; ++v) EXPECT_LT((rest.rotation[v] - r.transpose()).norm(), 1e-9);
}

// On a polygon the free vertex between two template vertices of a scaled, turned copy returns to
// the circle beside the template edge's point at the same ratio (0.02 mm from it; the chord is 0.07 mm inside).
TEST(RestPositions, FreeVertexOnAPolygonEdge2D) {
  const Template<2> t = round_template<2>(10.0, Point<2>::Zero(), 24);
  const double angle = -0.7, s = 0.8;
  Eigen::Matrix2d r;
  r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  PointList<2> q;
  std::vector<int> ids;
  const Point<2> inserted = 0.3 * t.positions[10] + 0.7 * t.positions[11];
  for (int i = 0; i < 24; ++i) {
    q.push_back(s * r * t.positions[i]);
    ids.push_back(i);
    if (i == 10) {
      q.push_back(s * r * inserted);
      ids.push_back(-1);
    }
  }
  const Snake<2> snake(q, Connectivity::polygon(25), ids);
  const RestPositions<2> rest = rest_positions(t, snake);
  EXPECT_NEAR(rest.positions[11].norm(), 10.0, 0.025);
  EXPECT_LT((rest.positions[11].normalized() - inserted.normalized()).norm(), 1e-3);
  EXPECT_GT(10.0 - inserted.norm(), 0.07);
  EXPECT_EQ(rest.positions[12], t.positions[11]);
}

}  // namespace
}  // namespace dsnake
