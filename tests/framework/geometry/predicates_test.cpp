// The exact intersection predicates (framework/geometry/predicates.h) and the triangle measures
// (framework/geometry/triangle_measures.h) on hand-made cases: crossing, touching, disjoint and
// coplanar-overlapping facets; a right triangle's normal, area and angles.
#include "framework/geometry/predicates.h"
#include "framework/geometry/triangle_measures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace dsnake {
namespace {

TEST(SegmentsIntersect, CrossingTouchingAndApart) {
  EXPECT_TRUE(segments_intersect({0, 0}, {2, 2}, {0, 2}, {2, 0}));   // proper crossing
  EXPECT_TRUE(segments_intersect({0, 0}, {2, 0}, {2, 0}, {3, 5}));   // a shared end
  EXPECT_TRUE(segments_intersect({0, 0}, {2, 0}, {1, 0}, {3, 0}));   // collinear overlap
  EXPECT_FALSE(segments_intersect({0, 0}, {2, 0}, {3, 0}, {4, 0}));  // collinear, apart
  EXPECT_FALSE(segments_intersect({0, 0}, {2, 2}, {0, 1}, {1, 2}));  // parallel
}

TEST(TrianglesIntersect, PiercingTouchingCoplanarAndApart) {
  const std::array<Point<3>, 3> flat = {Point<3>(0, 0, 0), Point<3>(2, 0, 0), Point<3>(0, 2, 0)};
  const std::array<Point<3>, 3> piercing = {Point<3>(0.5, 0.5, -1), Point<3>(0.5, 0.5, 1), Point<3>(3, 3, 0.5)};
  const std::array<Point<3>, 3> above = {Point<3>(0, 0, 1), Point<3>(2, 0, 1), Point<3>(0, 2, 1)};
  const std::array<Point<3>, 3> touching = {Point<3>(2, 0, 0), Point<3>(3, 0, 1), Point<3>(3, 1, 1)};
  const std::array<Point<3>, 3> coplanar = {Point<3>(0.5, 0.5, 0), Point<3>(3, 0.5, 0), Point<3>(0.5, 3, 0)};
  EXPECT_TRUE(triangles_intersect(flat, piercing));
  EXPECT_TRUE(triangles_intersect(piercing, flat));
  EXPECT_FALSE(triangles_intersect(flat, above));
  EXPECT_TRUE(triangles_intersect(flat, touching));
  EXPECT_TRUE(triangles_intersect(flat, coplanar));
}

TEST(TriangleMeasures, RightTriangle) {
  const Point<3> a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_EQ(triangle_normal(a, b, c), Point<3>(0, 0, 1));
  EXPECT_DOUBLE_EQ(triangle_area(a, b, c), 0.5);
  EXPECT_NEAR(angle_at(a, b, c), std::numbers::pi / 2, 1e-15);
  EXPECT_NEAR(min_angle(a, b, c), std::numbers::pi / 4, 1e-15);
  EXPECT_NEAR(min_angle_key(a, b, c), angle_key(std::numbers::pi / 4), 1e-15);
  EXPECT_EQ(area_normal(a, b, c), Point<3>(0, 0, 1));
  EXPECT_NEAR(cos_between(Point<3>(1, 0, 0), Point<3>(1, 1, 0)), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(triangle_normal(a, b, 2 * b), Point<3>::Zero());  // degenerate
}

}  // namespace
}  // namespace dsnake
