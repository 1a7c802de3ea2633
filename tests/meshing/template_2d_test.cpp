// 2D templates from label images: a disk in an anisotropic grid, the ITK corpus callosum mean
// shape (a signed distance map, made into a label here), mirroring, components and holes.
#include "framework/io/image_io.h"
#include "tests/meshing/label_test_helpers.h"

#include <gtest/gtest.h>

#include <optional>
#include <set>

namespace dsnake {
namespace {

using test_support::label_image;

constexpr double kPi = 3.14159265358979323846;

Grid<2> disk_grid() {
  Grid<2> g;
  g.size = GridIndex<2>(60, 36);
  g.spacing = Point<2>(0.7, 1.2);
  g.origin = Point<2>(5, -8);
  return g;
}
const Point<2> kDiskCentre(5 + 0.7 * 29, -8 + 1.2 * 17);

LabelTemplate<2> make(const Image<2>& labels, int label, int vertices, std::optional<MirrorPlane> mirror = {}) {
  LabelTemplateOptions o;
  o.label = label;
  o.vertices = vertices;
  o.mirror = mirror;
  return template_from_labels<2>(labels, o, "synthetic");
}

// Measured: Dice against the label and the signed area, computed here.
double dice_of(const LabelTemplate<2>& t, const Image<2>& labels, int label) {
  return dice<2>(rasterize_interior<2>({t.shape.positions, t.shape.connectivity}, labels.grid()),
                 label_indicator(labels, label));
}

TEST(Template2d, DiskIsACounterClockwiseContour) {
  const double r = 15;
  const Image<2> labels = label_image<2>(disk_grid(), [&](const Point<2>& x) { return (x - kDiskCentre).norm() <= r; }, 4);
  const LabelTemplate<2> t = make(labels, 4, 200);
  ASSERT_EQ(t.shape.num_vertices(), 200);
  const double area = signed_measure<2>(t.shape.positions, t.shape.connectivity);
  EXPECT_NEAR(area, kPi * r * r, 0.03 * kPi * r * r);  // positive: counter-clockwise
  EXPECT_EQ(count_self_intersections<2>({t.shape.positions, t.shape.connectivity}), 0);
  for (const auto& p : t.shape.positions) EXPECT_NEAR((p - kDiskCentre).norm(), r, 0.8);
  const double d = dice_of(t, labels, 4);
  std::printf("[ measured ] disk 200: Dice %.5f, area %.1f (pi r^2 %.1f)\n", d, area, kPi * r * r);
  EXPECT_GE(d, 0.99);
  EXPECT_NEAR(t.report.dice, d, 1e-12);
  // Equal arc-length steps.
  for (int i = 0; i < 200; ++i)
    EXPECT_NEAR((t.shape.positions[(i + 1) % 200] - t.shape.positions[i]).norm(), 2 * kPi * r / 200, 0.1);
}

TEST(Template2d, CorpusCallosumMeanShape) {
  // The file is a signed distance map (negative inside; hundreds of distinct values), not a
  // label image: the label is its voxels <= 0.
  const Image<2> dist = read_image<2>(std::string(DSNAKE_SCANS_DIR) + "/itk/CorpusCallosumMeanShape.mha");
  EXPECT_GT(std::set<float>(dist.data().begin(), dist.data().end()).size(), 100u);
  Image<2> labels(dist.grid(), 0.0f);
  for (int64_t i = 0; i < dist.num_voxels(); ++i) labels[i] = dist[i] <= 0 ? 1.0f : 0.0f;
  const LabelTemplate<2> t = make(labels, 1, 120);
  ASSERT_EQ(t.shape.num_vertices(), 120);
  EXPECT_GT(signed_measure<2>(t.shape.positions, t.shape.connectivity), 0);
  EXPECT_EQ(count_self_intersections<2>({t.shape.positions, t.shape.connectivity}), 0);
  EXPECT_EQ(t.report.mask.components, 1);
  const double d = dice_of(t, labels, 1);
  std::printf("[ measured ] corpus callosum 120: Dice %.5f (%ld pixels)\n", d, long(t.report.mask.label_voxels));
  EXPECT_GE(d, 0.97);
}

TEST(Template2d, MirrorReflectsAndStaysCounterClockwise) {
  const Point<2> c = kDiskCentre + Point<2>(6, 3);
  const Image<2> labels = label_image<2>(disk_grid(), [&](const Point<2>& x) {
    return std::abs(x.x() - c.x()) <= 8 && std::abs(x.y() - c.y()) <= 5 && x.x() + x.y() < c.x() + c.y() + 6;
  }, 1);
  const LabelTemplate<2> plain = make(labels, 1, 64);
  for (int axis = 0; axis < 2; ++axis) {
    const double offset = c[axis] - 2.3;  // a plane of the caller's, off the grid's mid-plane
    const LabelTemplate<2> m = make(labels, 1, 64, MirrorPlane{axis, offset});
    for (int v = 0; v < 64; ++v) {
      Point<2> r = plain.shape.positions[(64 - v) % 64];  // vertex 0 kept, order reversed
      r[axis] = 2 * offset - r[axis];
      ASSERT_LT((m.shape.positions[v] - r).norm(), 1e-12) << "vertex " << v;
    }
    EXPECT_NEAR(signed_measure<2>(m.shape.positions, m.shape.connectivity),
                signed_measure<2>(plain.shape.positions, plain.shape.connectivity), 1e-9);
    EXPECT_GT(signed_measure<2>(m.shape.positions, m.shape.connectivity), 0);
  }
}

TEST(Template2d, KeepsTheLargestComponentAndFillsHoles) {
  const Image<2> labels = label_image<2>(disk_grid(), [&](const Point<2>& x) {
    const double d = (x - kDiskCentre).norm();
    return (d <= 12 && d >= 4) || (x - kDiskCentre - Point<2>(-17, 0)).norm() <= 2;  // a ring, a dot
  }, 1);
  const LabelTemplate<2> t = make(labels, 1, 100);
  EXPECT_EQ(t.report.mask.components, 2);
  EXPECT_GT(t.report.mask.filled_voxels, 0);
  for (const auto& p : t.shape.positions) EXPECT_NEAR((p - kDiskCentre).norm(), 12, 1.0);  // outer rim only
}

}  // namespace
}  // namespace dsnake
