// The shared discrete operators (framework/operators/mesh_operators.h) against hand-computed
// values: the umbrella Laplacian of a regular polygon and of a sphere's vertices, the
// combinatorial Laplacian's rows, the lumped mass (perimeter, area) and the stiffness (rows that
// sum to zero, the cotangent weights of a right triangle).
#include "framework/operators/mesh_operators.h"

#include "tests/test_meshes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <numeric>

namespace dsnake {
namespace {

Snake<2> regular_polygon(int n, double r) {
  PointList<2> q(n);
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    q[i] = r * Point<2>(std::cos(a), std::sin(a));
  }
  std::vector<int> ids(n);
  std::iota(ids.begin(), ids.end(), 0);
  return Snake<2>(q, Connectivity::polygon(n), ids);
}

TEST(UmbrellaLaplacian, RegularPolygonPointsInwardsByOneMinusCos) {
  const int n = 12;
  const double r = 3.0;
  const Snake<2> s = regular_polygon(n, r);
  for (int v = 0; v < n; ++v) {
    // q_v minus the mean of its two neighbours: (1 - cos(2 pi / n)) q_v.
    const Point<2> l = umbrella_laplacian<2>(s.connectivity(), s.positions(), v);
    EXPECT_NEAR((l - (1 - std::cos(2 * std::numbers::pi / n)) * s.positions()[v]).norm(), 0.0, 1e-13);
    EXPECT_NEAR((one_ring_mean<2>(s.connectivity(), s.positions(), v) + l - s.positions()[v]).norm(), 0.0, 1e-15);
  }
}

TEST(UmbrellaLaplacian, SphereVertexPointsOutwardsAndIsTheScaledCombinatorialLaplacian) {
  const Snake<3> s = test::icosphere(2, 1.0);
  const Connectivity& c = s.connectivity();
  const Eigen::SparseMatrix<double> lc = combinatorial_laplacian(c);
  for (int v = 0; v < s.num_vertices(); ++v) {
    const Point<3> l = umbrella_laplacian<3>(c, s.positions(), v);
    EXPECT_GT(l.dot(s.positions()[v]), 0.0);  // the one-ring's mean lies inside the sphere
    EXPECT_EQ(umbrella_weight(c, v), double(c.neighbors(v).size()));
    double row = 0;
    for (int w = 0; w < s.num_vertices(); ++w) row += lc.coeff(v, w);
    EXPECT_EQ(row, 0.0);
    EXPECT_EQ(lc.coeff(v, v), double(c.neighbors(v).size()));
    // W^-1 Lc q = L q
    Point<3> lq = Point<3>::Zero();
    for (Eigen::SparseMatrix<double>::InnerIterator it(lc, v); it; ++it) lq += it.value() * s.positions()[it.row()];
    EXPECT_NEAR((lq / umbrella_weight(c, v) - l).norm(), 0.0, 1e-14);
  }
}

TEST(LumpedMass, SumsToThePerimeterAndTheArea) {
  const Snake<2> polygon = regular_polygon(16, 2.0);
  std::vector<double> local, mass;
  element_stiffness_and_mass<2>(polygon.positions(), element_vertices<2>(polygon.connectivity()), local, mass);
  EXPECT_NEAR(std::accumulate(mass.begin(), mass.end(), 0.0), 16 * 2 * 2.0 * std::sin(std::numbers::pi / 16), 1e-12);
  const Snake<3> sphere = test::icosphere(2, 1.0);
  const std::vector<int> elements = element_vertices<3>(sphere.connectivity());
  element_stiffness_and_mass<3>(sphere.positions(), elements, local, mass);
  double area = 0;
  for (const Triangle& t : sphere.connectivity().triangles())
    area += 0.5 * (sphere.positions()[t[1]] - sphere.positions()[t[0]])
                      .cross(sphere.positions()[t[2]] - sphere.positions()[t[0]])
                      .norm();
  EXPECT_NEAR(std::accumulate(mass.begin(), mass.end(), 0.0), area, 1e-12);
}

TEST(Stiffness, RowsSumToZeroAndRightTriangleHasCotangentWeights) {
  const Snake<3> sphere = test::icosphere(1, 1.0);
  std::vector<double> mass;
  const Eigen::SparseMatrix<double> k = stiffness_matrix<3>(sphere, element_vertices<3>(sphere.connectivity()), mass);
  for (int v = 0; v < sphere.num_vertices(); ++v) {
    double row = 0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(k, v); it; ++it) row += it.value();
    EXPECT_NEAR(row, 0.0, 1e-12);
    EXPECT_GT(k.coeff(v, v), 0.0);
  }
  // One right isosceles triangle (0,0,0), (1,0,0), (0,1,0): K_12 = -1/2 cot(90 deg) = 0 and
  // K_01 = -1/2 cot(45 deg) = -1/2; mixed Voronoi areas at a right (not obtuse) triangle:
  // 1/4 at the right angle, 1/8 at the others.
  const PointList<3> q = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  std::vector<double> local;
  element_stiffness_and_mass<3>(q, {0, 1, 2}, local, mass);
  EXPECT_NEAR(local[3 * 1 + 2], 0.0, 1e-15);
  EXPECT_NEAR(local[3 * 0 + 1], -0.5, 1e-15);
  EXPECT_NEAR(local[3 * 0 + 0], 1.0, 1e-15);
  EXPECT_NEAR(mass[0], 0.25, 1e-15);
  EXPECT_NEAR(mass[1], 0.125, 1e-15);
  EXPECT_NEAR(mass[2], 0.125, 1e-15);
}

}  // namespace
}  // namespace dsnake
