// Label masks and surface extraction: selection, largest component, cavity filling, border
// padding; marching cubes/squares give closed, manifold, outward surfaces whose topology is that
// of the 6-connected (2D: 4-connected) object, checked on random masks against the Euler
// characteristic of the object's cubical complex.
#include "framework/metrics/metrics.h"
#include "meshing/label_mask.h"
#include "meshing/surface_extraction.h"
#include "tests/meshing/label_test_helpers.h"

#include <gtest/gtest.h>

#include <random>

namespace dsnake {
namespace {

// A padded mask of n^3 random voxels (probability p inside), one empty voxel on every side.
LabelMask<3> random_mask(int n, double p, unsigned seed) {
  LabelMask<3> m;
  m.grid.size = GridIndex<3>::Constant(n + 2);
  m.grid.spacing = Point<3>(0.7, 1.1, 1.3);
  m.grid.origin = Point<3>(-3, 2, 5);
  m.inside.assign(size_t(m.grid.num_voxels()), 0);
  std::mt19937 rng(seed);
  std::bernoulli_distribution coin(p);
  for (int z = 1; z <= n; ++z)
    for (int y = 1; y <= n; ++y)
      for (int x = 1; x <= n; ++x) m.inside[size_t(m.grid.linear(GridIndex<3>(x, y, z)))] = coin(rng);
  return m;
}

TEST(MarchingCubes, RandomMasksGiveTheTopologyOfThe6ConnectedObject) {
  int checked = 0;
  for (unsigned seed = 1; seed <= 60; ++seed) {
    const LabelMask<3> m = random_mask(6, 0.3 + 0.4 * (seed % 3) / 2.0, seed);
    const ExtractedSurface s = marching_cubes(m);
    if (s.triangles.empty()) continue;
    const Connectivity c = Connectivity::mesh(int(s.points.size()), s.triangles);
    ASSERT_EQ(c.closed_manifold_problem(), "") << "seed " << seed;
    EXPECT_EQ(c.euler_characteristic(), 2 * test_support::object_euler(m)) << "seed " << seed;
    // Every inside voxel centre is inside the surface, every outside one outside.
    Image<3> truth(m.grid), raster = rasterize_interior<3>({s.points, c}, m.grid);
    for (int64_t i = 0; i < truth.num_voxels(); ++i) truth[i] = m.inside[size_t(i)];
    EXPECT_EQ(dice<3>(raster, truth), 1.0) << "seed " << seed;
    EXPECT_GT(signed_measure<3>(s.points, c), 0) << "seed " << seed;
    EXPECT_EQ(count_self_intersections<3>({s.points, c}), 0) << "seed " << seed;
    ++checked;
  }
  EXPECT_EQ(checked, 60);
}

// Two voxels touching along an edge, and two at a corner: apart (6-connectivity), two spheres.
TEST(MarchingCubes, DiagonalVoxelsAreApart) {
  for (const GridIndex<3>& other : {GridIndex<3>(2, 2, 1), GridIndex<3>(2, 2, 2)}) {
    LabelMask<3> m;
    m.grid.size = GridIndex<3>::Constant(4);
    m.inside.assign(64, 0);
    m.inside[size_t(m.grid.linear(GridIndex<3>(1, 1, 1)))] = 1;
    m.inside[size_t(m.grid.linear(other))] = 1;
    const ExtractedSurface s = marching_cubes(m);
    const Connectivity c = Connectivity::mesh(int(s.points.size()), s.triangles);
    EXPECT_EQ(c.closed_manifold_problem(), "");
    EXPECT_EQ(c.euler_characteristic(), 4);
  }
}

// The six voxels of a 2x2x2 block without two opposite corners form a ring (6-connected, no
// square): a torus. The cube between them is the tunnel case of marching cubes.
TEST(MarchingCubes, SixVoxelRingAroundADiagonalIsATorus) {
  LabelMask<3> m;
  m.grid.size = GridIndex<3>::Constant(4);
  m.inside.assign(64, 0);
  for (int c = 1; c < 7; ++c) m.inside[size_t(m.grid.linear(GridIndex<3>(1 + (c & 1), 1 + ((c >> 1) & 1), 1 + (c >> 2))))] = 1;
  EXPECT_EQ(test_support::object_euler(m), 0);
  const ExtractedSurface s = marching_cubes(m);
  const Connectivity c = Connectivity::mesh(int(s.points.size()), s.triangles);
  EXPECT_EQ(c.closed_manifold_problem(), "");
  EXPECT_EQ(c.euler_characteristic(), 0);
  EXPECT_EQ(count_self_intersections<3>({s.points, c}), 0);
  EXPECT_GT(signed_measure<3>(s.points, c), 0);
}

// A 2D mask's contours: counter-clockwise around the inside, clockwise around holes, so the
// count of CCW minus CW contours is the Euler characteristic (components - holes, 4/8).
TEST(MarchingSquares, ContoursCountComponentsMinusHoles) {
  LabelMask<2> m;
  m.grid.size = GridIndex<2>(12, 9);
  m.grid.spacing = Point<2>(0.5, 2.0);
  m.grid.origin = Point<2>(4, -7);
  m.inside.assign(size_t(m.grid.num_voxels()), 0);
  auto set = [&](int x, int y) { m.inside[size_t(m.grid.linear(GridIndex<2>(x, y)))] = 1; };
  for (int x = 1; x <= 5; ++x)
    for (int y = 1; y <= 5; ++y)
      if (x != 3 || y != 3) set(x, y);  // a ring: one component, one hole
  set(7, 2), set(8, 3);                 // diagonal pixels: two components (4-connectivity)
  const auto contours = marching_squares(m);
  int ccw = 0, cw = 0;
  for (const auto& c : contours) (signed_measure<2>(c, Connectivity::polygon(int(c.size()))) > 0 ? ccw : cw)++;
  EXPECT_EQ(ccw, 3);
  EXPECT_EQ(cw, 1);
}

TEST(LabelMask, KeepsTheLargestComponentFillsCavitiesAndPads) {
  Grid<3> g;
  g.size = GridIndex<3>(20, 12, 12);
  g.spacing = Point<3>(1, 2, 3);
  g.origin = Point<3>(10, 20, 30);
  Image<3> labels(g, 0.0f);
  for (int z = 2; z <= 8; ++z)  // a hollow box (cavity of 3^3) of label 5, and a small one apart
    for (int y = 2; y <= 8; ++y)
      for (int x = 2; x <= 8; ++x) {
        const bool shell = std::max({std::abs(x - 5), std::abs(y - 5), std::abs(z - 5)}) >= 2;
        labels.at(GridIndex<3>(x, y, z)) = shell ? 5.0f : 0.0f;
      }
  labels.at(GridIndex<3>(15, 5, 5)) = 5;
  labels.at(GridIndex<3>(5, 5, 5)) = 5;  // an island in the cavity: filled with it
  labels.at(GridIndex<3>(17, 5, 5)) = 2;  // another label
  const LabelMask<3> m = extract_label_mask(labels, 5);
  EXPECT_EQ(m.report.label_voxels, 7 * 7 * 7 - 27 + 2);
  EXPECT_EQ(m.report.components, 3);
  EXPECT_EQ(m.report.kept_voxels, 7 * 7 * 7 - 27);
  EXPECT_EQ(m.report.filled_voxels, 27);
  EXPECT_FALSE(m.report.touches_border);
  EXPECT_EQ(m.grid.size, GridIndex<3>(22, 14, 14));
  EXPECT_TRUE(m.grid.origin.isApprox(Point<3>(9, 18, 27)));
  int64_t inside = 0;
  for (uint8_t v : m.inside) inside += v;
  EXPECT_EQ(inside, 7 * 7 * 7);
  EXPECT_EQ(m.inside[size_t(m.grid.linear(GridIndex<3>(16, 6, 6)))], 0);  // the small component
  EXPECT_EQ(extract_label_mask(labels, 9).report.label_voxels, 0);
}

// An object cut by the image border still gives a closed surface (the padding closes it).
TEST(LabelMask, BorderTouchingLabelGivesAClosedSurface) {
  Grid<3> g;
  g.size = GridIndex<3>(10, 10, 10);
  Image<3> labels(g, 0.0f);
  for (int64_t i = 0; i < labels.num_voxels(); ++i)
    if (g.index(i)[0] <= 4) labels[i] = 1;  // half the volume, three faces on the border
  const LabelMask<3> m = extract_label_mask(labels, 1);
  EXPECT_TRUE(m.report.touches_border);
  const ExtractedSurface s = marching_cubes(m);
  const Connectivity c = Connectivity::mesh(int(s.points.size()), s.triangles);
  EXPECT_EQ(c.closed_manifold_problem(), "");
  EXPECT_EQ(c.euler_characteristic(), 2);
  // The box spans x in [-0.5, 4.5]: the surface stops half a voxel beyond the last voxels.
  double lo = 1e9, hi = -1e9;
  for (const auto& p : s.points) lo = std::min(lo, p.x()), hi = std::max(hi, p.x());
  EXPECT_DOUBLE_EQ(lo, -0.5);
  EXPECT_DOUBLE_EQ(hi, 4.5);
}

}  // namespace
}  // namespace dsnake
