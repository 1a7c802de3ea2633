// Symmetry planes of label maps and images: synthetic data symmetric about a known plane off
// the grid's centre (through a voxel centre, a face between voxels, or between them), on
// anisotropic grids with a non-zero origin, recovered to within a tenth of a voxel.
#include "meshing/symmetry_plane.h"
#include "tests/meshing/label_test_helpers.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>

namespace dsnake {
namespace {

// 64 x 44 x 41 voxels of 0.8 x 1.0 x 1.25 mm, origin (-37.5, 18.7, -7.1).
Grid<3> grid_3d() { return test_support::anisotropic_grid(Point<3>(-12.3, 40.2, 17.9), Point<3>(50.4, 43, 50)); }

// The plane normal to `axis` through index `index` along it (the grid's centre is at 31.5,
// 21.5, 20).
MirrorPlane plane_at(const Grid<3>& g, int axis, double index) {
  return {axis, g.origin[axis] + index * g.spacing[axis]};
}

// A point at `along` mm from the plane (along its normal) and `across` elsewhere, in world.
Point<3> at(const MirrorPlane& p, const Grid<3>& g, double along, const Point<3>& across) {
  Point<3> x = g.origin + 0.5 * (g.size.cast<double>() - Point<3>::Ones()).cwiseProduct(g.spacing) + across;
  x[p.axis] = p.offset + along;
  return x;
}

// An atlas-like label map symmetric about `p`: a left/right pair of balls (labels 11 and 12,
// different values as atlases number them), a pair of boxes (21 and 22) and a midline ellipsoid
// (5), each placed off the grid's other mid-planes.
Image<3> paired_labels(const Grid<3>& g, const MirrorPlane& p) {
  const int a = p.axis, b = (a + 1) % 3;
  Point<3> off = Point<3>::Zero();
  off[b] = 3.1;
  Image<3> img(g, 0.0f);
  for (int64_t v = 0; v < img.num_voxels(); ++v) {
    const Point<3> x = g.to_physical(g.index(v));
    const Point<3> r = reflect<3>(x, p);  // the same test on both sides: exactly symmetric shapes
    auto ball = [&](const Point<3>& y) { return (y - at(p, g, -10.5, off)).norm() <= 7.5; };
    auto box = [&](const Point<3>& y) {
      const Point<3> d = (y - at(p, g, -4.1, -2 * off)).cwiseAbs();
      return d[a] <= 2.6 && d[b] <= 4.4 && d[(a + 2) % 3] <= 5.0;
    };
    const Point<3> e = (x - at(p, g, 0, off)).cwiseQuotient(Point<3>(5, 6, 7));
    if (ball(x)) img[v] = 11;
    else if (ball(r)) img[v] = 12;
    else if (box(x)) img[v] = 21;
    else if (box(r)) img[v] = 22;
    else if (e.norm() <= 1) img[v] = 5;
  }
  return img;
}

// An image symmetric about `p`: a bright head-like ellipsoid across the plane, smooth blobs
// mirrored across it, and a noise pattern that is itself symmetric.
Image<3> symmetric_image(const Grid<3>& g, const MirrorPlane& p) {
  const int a = p.axis;
  Point<3> off = Point<3>::Zero();
  off[(a + 1) % 3] = -2.7;
  auto blobs = [&](const Point<3>& y) {
    return 120 * std::exp(-(y - at(p, g, -8.5, off)).squaredNorm() / 18.0) +
           60 * std::exp(-(y - at(p, g, -3.0, -off)).squaredNorm() / 8.0);
  };
  auto texture = [&](const Point<3>& y) {  // even in the distance to the plane
    const double d = std::abs(y[a] - p.offset);
    return 8 * std::sin(1.7 * d + 0.3 * y[(a + 1) % 3]) * std::cos(0.9 * y[(a + 2) % 3]);
  };
  Image<3> img(g, 0.0f);
  for (int64_t v = 0; v < img.num_voxels(); ++v) {
    const Point<3> x = g.to_physical(g.index(v));
    const Point<3> e = (x - at(p, g, 0, off)).cwiseQuotient(Point<3>(16, 20, 18));
    img[v] = float((e.norm() <= 1 ? 40 : 0) + blobs(x) + blobs(reflect<3>(x, p)) + texture(x));
  }
  return img;
}

// Planes through a voxel centre, a face, and two places in between, off the grid's centre.
constexpr double kIndices[] = {24.0, 24.5, 25.37, 27.81};

// The largest error (voxels) of `find` on `make`'s data over planes normal to x and y.
double largest_error(const std::function<MirrorPlane(const Image<3>&, int)>& find,
                     const std::function<Image<3>(const Grid<3>&, const MirrorPlane&)>& make) {
  const Grid<3> g = grid_3d();
  double worst = 0;
  for (int axis : {0, 1}) {
    for (double index : kIndices) {
      const double i = axis == 0 ? index : index - 6;  // y: 44 voxels, centre 21.5
      const MirrorPlane truth = plane_at(g, axis, i);
      const MirrorPlane found = find(make(g, truth), axis);
      EXPECT_EQ(found.axis, axis);
      EXPECT_NEAR(found.offset, truth.offset, 0.1 * g.spacing[axis]) << "axis " << axis << " index " << i;
      worst = std::max(worst, std::abs(found.offset - truth.offset) / g.spacing[axis]);
    }
  }
  return worst;
}

TEST(SymmetryPlane, LabelMapPlaneWithinATenthOfAVoxel) {
  const double worst = largest_error(label_symmetry_plane<3>, paired_labels);
  std::printf("[ measured ] label map: largest error %.3f voxels\n", worst);
}

TEST(SymmetryPlane, ImagePlaneWithinATenthOfAVoxel) {
  const double worst = largest_error(image_symmetry_plane<3>, symmetric_image);
  std::printf("[ measured ] image: largest error %.3f voxels\n", worst);
}

TEST(SymmetryPlane, TwoDimensionalLabelsAndImages) {
  Grid<2> g;
  g.size = GridIndex<2>(70, 40);
  g.spacing = Point<2>(0.6, 1.1);
  g.origin = Point<2>(4.0, -9.0);
  const double c = g.origin.x() + 29.3 * g.spacing.x();
  const Point<2> left(c - 7.1, g.origin.y() + 19 * 1.1);
  auto disk = [&](const Point<2>& y) { return (y - left).norm() <= 5.0; };
  Image<2> labels(g, 0.0f), image(g, 0.0f);
  for (int64_t v = 0; v < labels.num_voxels(); ++v) {
    const Point<2> x = g.to_physical(g.index(v)), r(2 * c - x.x(), x.y());
    labels[v] = disk(x) ? 1.0f : disk(r) ? 2.0f : 0.0f;
    image[v] = float(std::exp(-(x - left).squaredNorm() / 20) + std::exp(-(r - left).squaredNorm() / 20));
  }
  EXPECT_NEAR(label_symmetry_plane<2>(labels, 0).offset, c, 0.1 * g.spacing.x());
  EXPECT_NEAR(image_symmetry_plane<2>(image, 0).offset, c, 0.1 * g.spacing.x());
}

// Control: the label plane follows the labels' counterparts, not the grid: a map whose pairs sit
// about a plane 6.5 voxels off the centre is not mirrored about the centre.
TEST(SymmetryPlane, FarFromTheGridCentre) {
  const Grid<3> g = grid_3d();
  const MirrorPlane truth = plane_at(g, 0, 38.0);
  const MirrorPlane found = label_symmetry_plane<3>(paired_labels(g, truth), 0);
  EXPECT_NEAR(found.offset, truth.offset, 0.1 * g.spacing.x());
}

TEST(SymmetryPlane, ReflectAndExtent) {
  const Point<3> r = reflect<3>(Point<3>(1, 2, 3), MirrorPlane{1, 0.5});
  EXPECT_EQ(r, Point<3>(1, -1, 3));
  const Grid<3> g = grid_3d();
  const auto [lo, hi] = world_extent<3>(g, 2);
  EXPECT_NEAR(lo, g.origin.z() - 0.5 * 1.25, 1e-12);
  EXPECT_NEAR(hi, g.origin.z() + 40.5 * 1.25, 1e-12);
}

TEST(SymmetryPlane, RefusesWhatItCannotSearch) {
  Grid<3> g = grid_3d();
  EXPECT_THROW(label_symmetry_plane<3>(Image<3>(g, 0.0f), 0), std::invalid_argument);  // no label
  EXPECT_THROW(image_symmetry_plane<3>(Image<3>(g, 3.0f), 0), std::invalid_argument);  // constant
  EXPECT_THROW(label_symmetry_plane<3>(Image<3>(g, 1.0f), 3), std::invalid_argument);  // no axis 3
  g.direction = Eigen::AngleAxisd(0.3, Point<3>::UnitZ()).toRotationMatrix();
  EXPECT_THROW(label_symmetry_plane<3>(Image<3>(g, 1.0f), 0), std::invalid_argument);  // oblique
  EXPECT_THROW(image_symmetry_plane<3>(Image<3>(g, 1.0f), 0), std::invalid_argument);
}

}  // namespace
}  // namespace dsnake
