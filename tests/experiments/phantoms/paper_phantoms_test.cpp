// The paper's phantoms (experiments/phantoms/paper_phantoms.h): geometry against hand-computed values,
// meshes closed and outward, masks equal to the rendered images, correspondence targets on the
// true shapes.
#include "experiments/phantoms/paper_phantoms.h"
#include "experiments/phantoms/phantoms.h"
#include "tests/experiments/phantoms/phantom_test_support.h"
#include "framework/core/errors.h"
#include "framework/metrics/metrics.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <set>

namespace dsnake {
namespace {

template <int D>
Template<D> template_phantom(const std::string& spec) {
  const auto j = nlohmann::json::parse(spec);
  JsonReader r(j, "test", "template");
  auto t = make_template_phantom<D>(r);
  r.skip("transform");  // the experiment's placement, read by the experiment loader
  r.finish();
  return t;
}

template <int D>
std::vector<std::optional<Point<D>>> targets(const std::string& image, const std::string& tmpl) {
  return targets_of<D>(nlohmann::json::parse(image), nlohmann::json::parse(tmpl),
                            template_phantom<D>(tmpl));
}

// A closed, outward, genus-0 mesh.
void expect_closed_sphere(const Template<3>& t) {
  EXPECT_EQ(t.connectivity.closed_manifold_problem(), "");
  EXPECT_EQ(t.connectivity.euler_characteristic(), 2);
  EXPECT_GT(signed_measure<3>(t.positions, t.connectivity), 0.0);
}

// Binary phantom: every voxel is 85 inside the mask and 170 outside.
template <int D>
void expect_image_is_mask(const Phantom<D>& ph) {
  ASSERT_TRUE(ph.image.grid().same_geometry(ph.mask.grid()));
  int64_t wrong = 0, inside = 0;
  for (int64_t l = 0; l < ph.image.num_voxels(); ++l) {
    wrong += ph.image[l] != (ph.mask[l] != 0 ? 85.0f : 170.0f);
    inside += ph.mask[l] != 0;
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(inside, 0);
}

constexpr double kDeg = M_PI / 180.0;

TEST(PaperPhantoms, Star3dTemplateIsAClosedOutwardStarAtEveryLevel) {
  const int expected[3] = {26, 98, 386};
  for (int k = 0; k < 3; ++k) {
    const auto t = template_phantom<3>(R"({"phantom": "star", "subdivisions": )" + std::to_string(k) + "}");
    EXPECT_EQ(t.num_vertices(), expected[k]);
    EXPECT_EQ(t.connectivity.triangles().size(), 48u << (2 * k));
    expect_closed_sphere(t);
    // Subdivision is flat: the volume is the 26-vertex star's, 48 tetrahedra (tip, edge
    // midpoint, corner, centre) of volume 30 * (12 / sqrt 2) * (12 / sqrt 3) / 6 each.
    EXPECT_NEAR(signed_measure<3>(t.positions, t.connectivity), 8 * 30 * 144 / std::sqrt(6.0), 1e-9);
    const Point<3> c = Point<3>::Constant(39.5);  // the default 80^3 image's centre
    EXPECT_LT((t.positions[t.landmarks.at("tip+x")] - (c + Point<3>(30, 0, 0))).norm(), 1e-12);
    EXPECT_LT((t.positions[t.landmarks.at("tip-z")] - (c - Point<3>(0, 0, 30))).norm(), 1e-12);
    for (int v = 6; v < 26; ++v) EXPECT_NEAR((t.positions[v] - c).norm(), 12.0, 1e-12);
  }
  // The first 26 ids keep their positions under subdivision; vertex 25 is a corner.
  const auto t0 = template_phantom<3>(R"({"phantom": "star"})");
  const auto t2 = template_phantom<3>(R"({"phantom": "star", "subdivisions": 2})");
  for (int v = 0; v < 26; ++v) EXPECT_EQ(t0.positions[v], t2.positions[v]);
  EXPECT_LT((t0.positions[25] - Point<3>::Constant(39.5 - 12 / std::sqrt(3.0))).norm(), 1e-12);
}

TEST(PaperPhantoms, Star3dImageIsTheVoxelisedStar) {
  const auto ph = image_phantom<3>(R"({"phantom": "star"})");
  EXPECT_EQ(ph.image.size(), GridIndex<3>(80, 80, 80));
  expect_image_is_mask(ph);
  const double volume = 8 * 30 * 144 / std::sqrt(6.0);
  EXPECT_NEAR(mask_measure(ph.mask), volume, 0.03 * volume);
  EXPECT_EQ(ph.surface.num_vertices(), 26);
  // The rasterised star is the mask.
  EXPECT_EQ(rasterize_interior<3>({ph.surface.positions, ph.surface.connectivity}, ph.mask.grid()).data(),
            ph.mask.data());
  // Anisotropic spacing: the physical volume is kept.
  const auto an = image_phantom<3>(R"({"phantom": "star", "size": [80, 80, 40], "spacing": [1, 1, 2],
                                       "center": [39.5, 39.5, 39]})");
  EXPECT_NEAR(mask_measure(an.mask), volume, 0.04 * volume);
}

TEST(PaperPhantoms, PartialVolumeGreyLevelsAddUpToTheVolume) {
  const auto ph = image_phantom<3>(R"({"phantom": "star", "partial_volume": true, "size": [72, 72, 72]})");
  double covered = 0;
  for (float v : ph.image.data()) {
    ASSERT_GE(v, 85.0f);
    ASSERT_LE(v, 170.0f);
    covered += (170.0 - v) / 85.0;
  }
  const double volume = 8 * 30 * 144 / std::sqrt(6.0);
  EXPECT_NEAR(covered, volume, 0.02 * volume);
  std::set<float> levels(ph.image.data().begin(), ph.image.data().end());
  EXPECT_GT(levels.size(), 5u);  // grey boundary voxels
}

TEST(PaperPhantoms, Star3dTargetsAreTheTrueStarsVerticesAndMidpoints) {
  // Untransformed template of the image's star: targets are the template's own positions.
  const std::string image = R"({"phantom": "star", "size": [80, 80, 80]})";
  const std::string same = R"({"phantom": "star", "subdivisions": 2})";
  const auto t = template_phantom<3>(same);
  const auto tg = targets<3>(image, same);
  ASSERT_EQ(tg.size(), 386u);
  for (int v = 0; v < 386; ++v) EXPECT_LT((*tg[v] - t.positions[v]).norm(), 1e-12);
  // Another template shape and place: the targets stay on the image's star, vertex k < 26 on
  // the true vertex k, and every target on the true surface.
  const std::string other = R"({"phantom": "star", "subdivisions": 1, "outer_radius": 20, "inner_radius": 15,
                                "center": [30, 35, 40], "transform": {"scale": 1.2}})";
  const auto to = targets<3>(image, other);
  ASSERT_EQ(to.size(), 98u);
  const auto truth = image_phantom<3>(image).surface;
  for (int v = 0; v < 26; ++v) EXPECT_LT((*to[v] - truth.positions[v]).norm(), 1e-12);
  PointList<3> points;
  for (const auto& p : to) points.push_back(*p);
  for (double d : distances_to_surface<3>({truth.positions, truth.connectivity}, points)) EXPECT_LT(d, 1e-9);
}

TEST(PaperPhantoms, TetrisIsAClosed20VertexT) {
  const auto t = template_phantom<3>(R"({"phantom": "tetris"})");
  EXPECT_EQ(t.num_vertices(), 20);
  expect_closed_sphere(t);
  EXPECT_NEAR(signed_measure<3>(t.positions, t.connectivity), 4 * 1000.0, 1e-9);  // 4 cubes of 10^3
  const auto ph = image_phantom<3>(R"({"phantom": "tetris"})");
  EXPECT_EQ(ph.image.size(), GridIndex<3>(64, 64, 64));
  expect_image_is_mask(ph);
  // Faces at half-integer coordinates: exactly 4 x 1000 voxel centres inside.
  EXPECT_EQ(mask_measure(ph.mask), 4000.0);
  // The stem: the cell above the middle of the bar (cell units x in [1, 2], y in [1, 2]).
  EXPECT_EQ(ph.mask.at({31, 36, 31}), 1.0f);
  EXPECT_EQ(ph.mask.at({20, 36, 31}), 0.0f);
  const auto tg = targets<3>(R"({"phantom": "tetris", "cell": 12})", R"({"phantom": "tetris", "cell": 8})");
  const auto truth = template_phantom<3>(R"({"phantom": "tetris", "cell": 12})");
  ASSERT_EQ(tg.size(), 20u);
  for (int v = 0; v < 20; ++v) EXPECT_LT((*tg[v] - truth.positions[v]).norm(), 1e-12);
}

// Distance from x to the exact puzzle outline (default shape about c): the square's sides
// outside the necks, and the four circle arcs.
double puzzle_outline_distance(const Point<2>& x, const Point<2>& c) {
  const double a = 30, rho = 8, h = 4, w = std::sqrt(rho * rho - h * h);
  const Point<2> y = x - c;
  double best = 1e300;
  const Point<2> centers[4] = {{0, -a + h}, {a + h, 0}, {0, a + h}, {-a + h, 0}};
  for (const auto& k : centers) best = std::min(best, std::abs((y - k).norm() - rho));
  for (int side = 0; side < 4; ++side) {  // on a side line, within the corner and the neck
    const double along = side % 2 == 0 ? y.x() : y.y(), across = side % 2 == 0 ? y.y() : y.x();
    const double line = side < 2 ? (side == 0 ? -a : a) : (side == 2 ? a : -a);
    if (std::abs(along) <= a + 1e-12 && std::abs(along) >= w - 1e-12) best = std::min(best, std::abs(across - line));
  }
  return best;
}

TEST(PaperPhantoms, PuzzleHasItsLandmarksAndTheSquaresArea) {
  const auto t = template_phantom<2>(R"({"phantom": "puzzle"})");
  EXPECT_EQ(t.num_vertices(), 64);
  const Point<2> c(63.5, 63.5);
  const std::map<std::string, Point<2>> expected = {
      {"corner_bl", {-30, -30}}, {"hole_bottom", {0, -18}}, {"corner_br", {30, -30}}, {"knob_right", {42, 0}},
      {"corner_tr", {30, 30}},   {"knob_top", {0, 42}},     {"corner_tl", {-30, 30}}, {"hole_left", {-18, 0}}};
  ASSERT_EQ(t.landmarks.size(), 8u);
  for (const auto& [name, p] : expected) EXPECT_LT((t.positions[t.landmarks.at(name)] - (c + p)).norm(), 1e-9) << name;
  EXPECT_EQ(t.landmarks.at("knob_right"), 24);  // 8 vertices per piece
  for (const auto& p : t.positions) EXPECT_LT(puzzle_outline_distance(p, c), 1e-9);
  // Knobs and holes are the same circle segment: the area is the square's, (2 a)^2.
  const auto ph = image_phantom<2>(R"({"phantom": "puzzle"})");
  expect_image_is_mask(ph);
  EXPECT_NEAR(signed_measure<2>(ph.surface.positions, ph.surface.connectivity), 3600.0, 0.5);
  EXPECT_NEAR(mask_measure(ph.mask), 3600.0, 0.01 * 3600);
  EXPECT_EQ(ph.mask.at({63 + 40, 63}), 1.0f);  // in the right knob
  EXPECT_EQ(ph.mask.at({63 - 20, 63}), 0.0f);  // in the left hole
  // Perimeter: 4 sides of 2 (a - w) straight plus a 240-degree arc of radius 8 (the kinks at
  // the necks are vertices of the true outline, so only the arcs' chords fall short).
  double perimeter = 0;
  for (int v = 0; v < ph.surface.num_vertices(); ++v)
    perimeter += (ph.surface.positions[(v + 1) % ph.surface.num_vertices()] - ph.surface.positions[v]).norm();
  EXPECT_NEAR(perimeter, 4 * (2 * (30 - std::sqrt(48.0)) + 8 * 240 * kDeg), 1e-3);
}

TEST(PaperPhantoms, PuzzleTargetsLieOnTheTrueOutlineAtTheSameParameter) {
  const std::string image = R"({"phantom": "puzzle"})";
  const auto self = targets<2>(image, R"({"phantom": "puzzle", "vertices": 60})");
  const auto t = template_phantom<2>(R"({"phantom": "puzzle", "vertices": 60})");
  ASSERT_EQ(self.size(), 60u);
  for (int v = 0; v < 60; ++v) EXPECT_LT((*self[v] - t.positions[v]).norm(), 1e-12);
  const auto moved = targets<2>(image, R"({"phantom": "puzzle", "vertices": 60, "center": [50, 70],
                                          "half_width": 20, "knob_radius": 6, "knob_offset": 2})");
  const auto small = template_phantom<2>(R"({"phantom": "puzzle", "vertices": 60})");
  ASSERT_EQ(moved.size(), 60u);
  for (int v = 0; v < 60; ++v) {
    EXPECT_LT(puzzle_outline_distance(*moved[v], Point<2>(63.5, 63.5)), 1e-9);
    EXPECT_LT((*moved[v] - small.positions[v]).norm(), 1e-12);  // same parameter, same point
  }
}

TEST(PaperPhantoms, BarAndCShareConnectivityAndTheNeutralAxisLength) {
  const auto bar = template_phantom<3>(R"({"phantom": "bar", "length": 40, "width": 6, "rings": 11})");
  const auto c = template_phantom<3>(R"({"phantom": "c_shape", "length": 40, "width": 6, "rings": 11, "bend_deg": 180})");
  ASSERT_EQ(bar.num_vertices(), 44);
  ASSERT_EQ(c.num_vertices(), 44);
  EXPECT_EQ(bar.connectivity.triangles(), c.connectivity.triangles());
  expect_closed_sphere(bar);
  expect_closed_sphere(c);
  EXPECT_NEAR(signed_measure<3>(bar.positions, bar.connectivity), 40.0 * 36.0, 1e-9);
  // Ring centres of the C on the circle of radius R = 40 / pi about center + (0, R, 0), each
  // R * (pi / 10) of arc after the previous one: the bar's 4 units, kept.
  const double R = 40 / M_PI;
  const Point<3> centre = Point<3>::Constant(31.5) + Point<3>(0, R, 0);
  for (int i = 0; i < 11; ++i) {
    Point<3> ring = Point<3>::Zero(), straight = Point<3>::Zero();
    for (int j = 0; j < 4; ++j) ring += c.positions[4 * i + j] / 4, straight += bar.positions[4 * i + j] / 4;
    EXPECT_NEAR((ring - centre).norm(), R, 1e-9);
    EXPECT_NEAR(straight.x() - 31.5, -20 + 4 * i, 1e-9);
    if (i > 0) {
      Point<3> prev = Point<3>::Zero();
      for (int j = 0; j < 4; ++j) prev += c.positions[4 * (i - 1) + j] / 4;
      EXPECT_NEAR((ring - prev).norm(), 2 * R * std::sin(M_PI / 20), 1e-9);
    }
  }
  // The C's ends face each other across the circle: end rings at angles -90 and +90 degrees.
  EXPECT_NEAR(c.positions[c.landmarks.at("end0")].y() - c.positions[c.landmarks.at("end1")].y(), 0, 1e-9);
  // Every ring keeps its square cross-section (side 6).
  for (int i = 0; i < 11; ++i) EXPECT_NEAR((c.positions[4 * i] - c.positions[4 * i + 1]).norm(), 6, 1e-9);
  // No bend, no change.
  const auto flat = template_phantom<3>(R"({"phantom": "c_shape", "length": 40, "width": 6, "rings": 11, "bend_deg": 0})");
  EXPECT_EQ(flat.positions, bar.positions);
}

TEST(PaperPhantoms, LungSliceHasOneSharpCornerAndTargetsOnTheCurve) {
  const auto t = template_phantom<2>(R"({"phantom": "lung_slice"})");
  EXPECT_EQ(t.num_vertices(), 32);
  EXPECT_EQ(t.landmarks.at("corner"), 0);
  // Corner at -60 degrees, r = R (1 + e cos(2 (tc - 90)) + k) = 30 (1 + 0.15 * 0.5 + 0.4).
  const Point<2> c(63.5, 63.5);
  EXPECT_LT((t.positions[0] - (c + 30 * 1.475 * Point<2>(std::cos(-60 * kDeg), std::sin(-60 * kDeg)))).norm(), 1e-9);
  const auto ph = image_phantom<2>(R"({"phantom": "lung_slice"})");
  expect_image_is_mask(ph);
  EXPECT_GT(signed_measure<2>(ph.surface.positions, ph.surface.connectivity), 0.0);
  EXPECT_NEAR(mask_measure(ph.mask), signed_measure<2>(ph.surface.positions, ph.surface.connectivity), 0.01 * 3000);
  // The interior angle at the corner is atan(r / |r'+|) + atan(r / |r'-|), the one-sided
  // derivatives r'+- = R (-2 e sin(2 tc - 180) -+ 2 k / w): about 89 degrees; everywhere else the
  // fine outline turns by well under a degree per vertex.
  const auto& p = ph.surface.positions;
  const int n = ph.surface.num_vertices();
  auto turn = [&](int v) {
    const Point<2> a = p[(v + n - 1) % n] - p[v], b = p[(v + 1) % n] - p[v];
    return std::acos(a.dot(b) / (a.norm() * b.norm())) / kDeg;
  };
  const double smooth = -2 * 0.15 * std::sin(-300 * kDeg), kink = 2 * 0.4 / (30 * kDeg);
  const double corner = (std::atan(1.475 / std::abs(smooth - kink)) + std::atan(1.475 / std::abs(smooth + kink))) / kDeg;
  EXPECT_NEAR(corner, 88.8, 0.1);
  EXPECT_NEAR(turn(0), corner, 0.5);
  for (int v = 1; v < n; ++v) EXPECT_GT(turn(v), 178.0) << v;
  // Targets: on the exact curve r(t), and the template's own positions for the image's shape.
  const auto tg = targets<2>(R"({"phantom": "lung_slice", "radius": 35})", R"({"phantom": "lung_slice", "center": [60, 60]})");
  ASSERT_EQ(tg.size(), 32u);
  EXPECT_LT((*tg[0] - (c + 35 * 1.475 * Point<2>(std::cos(-60 * kDeg), std::sin(-60 * kDeg)))).norm(), 1e-9);
  for (const auto& x : tg) {
    const Point<2> y = *x - c;
    const double a = std::atan2(y.y(), y.x()), d = std::remainder(a + 60 * kDeg, 2 * M_PI);
    const double bump = std::max(0.0, 1 - std::abs(d) / (30 * kDeg));
    EXPECT_NEAR(y.norm(), 35 * (1 + 0.15 * std::cos(2 * a - M_PI) + 0.4 * bump * bump), 1e-9);
  }
  const auto own = targets<2>(R"({"phantom": "lung_slice"})", R"({"phantom": "lung_slice"})");
  for (int v = 0; v < 32; ++v) EXPECT_LT((*own[v] - t.positions[v]).norm(), 1e-12);
}

// rho(u) of the lung (paper_phantoms.h), recomputed here from the header's formula.
double lung_rho(const Point<3>& u, double notch = 0.3, double flattening = 0.15) {
  const Point<3> m = Point<3>(1, 0.3, -0.2).normalized();
  const double below = std::max(0.0, -u.z());
  return (1 - notch * std::exp(-(u - m).squaredNorm() / 0.245)) * (1 - flattening * below * below);
}

TEST(PaperPhantoms, LungTemplateIsAClosedLobeOf310Vertices) {
  const auto t = template_phantom<3>(R"({"phantom": "lung"})");
  EXPECT_EQ(t.num_vertices(), 310);
  expect_closed_sphere(t);
  const Point<3> c(114.5, 149.5, 39.5), axes(80, 120, 32);  // the default image's centre
  EXPECT_EQ(t.landmarks.at("apex"), 0);
  EXPECT_LT((t.positions[0] - (c + Point<3>(0, 0, 32 * lung_rho(Point<3>(0, 0, 1))))).norm(), 1e-9);
  EXPECT_LT((t.positions[309] - (c - Point<3>(0, 0, 32 * lung_rho(Point<3>(0, 0, -1))))).norm(), 1e-9);
  EXPECT_NEAR(lung_rho(Point<3>(0, 0, -1)), 0.85, 1e-3);  // the flattened base, far from the notch
  // Every vertex on the lobe: its direction u in the normalised frame has |.| = rho(u).
  for (const auto& p : t.positions) {
    const Point<3> y = (p - c).cwiseQuotient(axes);
    EXPECT_NEAR(y.norm(), lung_rho(y.normalized()), 1e-12);
  }
  // The notch: the medial (+x) side is pulled in by about notch_depth, the lateral one is not.
  EXPECT_NEAR(lung_rho(Point<3>(1, 0.3, -0.2).normalized()), 0.7 * (1 - 0.15 * 0.2 * 0.2 / 1.13), 1e-12);
  EXPECT_GT(lung_rho(Point<3>(-1, 0, 0)), 0.999);
}

TEST(PaperPhantoms, LungImageHasBronchiInsideTheMaskOnly) {
  // A smaller lobe on a smaller canvas keeps the test fast; the geometry scales.
  const std::string spec = R"({"phantom": "lung", "size": [120, 150, 48], "semi_axes": [40, 60, 16]})";
  const auto ph = image_phantom<3>(spec);
  const auto clean = image_phantom<3>(R"({"phantom": "lung", "size": [120, 150, 48], "semi_axes": [40, 60, 16],
                                          "bronchi": false})");
  expect_image_is_mask(clean);
  EXPECT_EQ(ph.mask.data(), clean.mask.data());
  const double volume = signed_measure<3>(ph.surface.positions, ph.surface.connectivity);
  EXPECT_NEAR(mask_measure(ph.mask), volume, 0.01 * volume);
  PointList<3> tube_voxels;
  for (int64_t l = 0; l < ph.image.num_voxels(); ++l) {
    if (ph.image[l] == clean.image[l]) continue;
    ASSERT_EQ(ph.mask[l], 1.0f);  // a bronchus voxel: inside the lung, at the background level
    ASSERT_EQ(ph.image[l], 170.0f);
    tube_voxels.push_back(ph.image.grid().to_physical(ph.image.grid().index(l)));
  }
  EXPECT_GT(tube_voxels.size(), 500u);
  // False edges inside: every bronchus voxel is away from the lung's wall.
  double nearest = 1e300;
  for (double d : distances_to_surface<3>({ph.surface.positions, ph.surface.connectivity}, tube_voxels))
    nearest = std::min(nearest, d);
  EXPECT_GT(nearest, 1.5);
  // Targets of a lung template on another lung: on the image lobe's true surface.
  const auto tg = targets<3>(spec, R"({"phantom": "lung", "semi_axes": [50, 50, 20], "rings": 7, "segments": 12})");
  ASSERT_EQ(tg.size(), 7u * 12 + 2);
  PointList<3> points;
  for (const auto& p : tg) points.push_back(*p);
  for (double d : distances_to_surface<3>({ph.surface.positions, ph.surface.connectivity}, points)) EXPECT_LT(d, 0.1);
}

TEST(PaperPhantoms, BoneIsAVoxelisedGenus2Plate) {
  const auto t = template_phantom<3>(R"({"phantom": "bone"})");
  EXPECT_EQ(t.num_vertices(), 48);
  EXPECT_EQ(t.connectivity.triangles().size(), 100u);
  EXPECT_EQ(t.connectivity.closed_manifold_problem(), "");
  EXPECT_EQ(t.connectivity.euler_characteristic(), -2);  // genus 2
  EXPECT_NEAR(signed_measure<3>(t.positions, t.connectivity), 13 * 1000.0, 1e-9);  // 15 cells - 2 holes
  const auto t1 = template_phantom<3>(R"({"phantom": "bone", "subdivisions": 1})");
  EXPECT_EQ(t1.num_vertices(), 198);
  EXPECT_EQ(t1.connectivity.euler_characteristic(), -2);
  EXPECT_NEAR(signed_measure<3>(t1.positions, t1.connectivity), 13 * 1000.0, 1e-9);
  const auto ph = image_phantom<3>(R"({"phantom": "bone"})");
  expect_image_is_mask(ph);
  EXPECT_EQ(mask_measure(ph.mask), 13000.0);  // faces at half-integers: exact
  EXPECT_EQ(ph.mask.at({31, 21, 31}), 0.0f);  // a hole
  EXPECT_EQ(ph.mask.at({31, 31, 31}), 1.0f);  // the bar between the holes
  const auto tg = targets<3>(R"({"phantom": "bone", "cell": 8})", R"({"phantom": "bone", "subdivisions": 1})");
  const auto truth = make_bone(Point<3>::Constant(31.5), BoneShape{8, 10}, 1);
  ASSERT_EQ(tg.size(), 198u);
  for (int v = 0; v < 198; ++v) EXPECT_LT((*tg[v] - truth.positions[v]).norm(), 1e-12);
}

// The ground truth an experiment gets (experiments/experiment.cpp): the phantom's mask and
// surface, and the targets of the template phantom.
template <int D>
Metrics metrics_of_template_at_truth(const std::string& image, const std::string& tmpl) {
  const auto ph = image_phantom<D>(image);
  GroundTruth<D> truth;
  truth.mask = ph.mask;
  truth.surface = ph.surface;
  truth.targets = targets<D>(image, tmpl);
  const Template<D> t = template_phantom<D>(tmpl);
  return compute_metrics<D>(Snake<D>::from_template(t, t.positions), truth);
}

TEST(PaperPhantoms, ATemplateAtTheTruthScoresPerfectly) {
  // Every family: the template of the image's own shape, unmoved, has zero correspondence error,
  // lies on the true surface and fills the mask.
  const std::vector<std::pair<std::string, std::string>> cases3 = {
      {R"({"phantom": "star"})", R"({"phantom": "star", "subdivisions": 1})"},
      {R"({"phantom": "tetris"})", R"({"phantom": "tetris"})"},
      {R"({"phantom": "bone"})", R"({"phantom": "bone", "subdivisions": 1})"},
      {R"({"phantom": "lung", "size": [100, 130, 40], "semi_axes": [40, 55, 15]})",
       R"({"phantom": "lung", "center": [49.5, 64.5, 19.5], "semi_axes": [40, 55, 15], "rings": 40, "segments": 80})"}};
  for (const auto& [image, tmpl] : cases3) {
    const Metrics m = metrics_of_template_at_truth<3>(image, tmpl);
    EXPECT_LT(*m.correspondence_error_max, 1e-9) << image;
    EXPECT_LT(*m.mean_surface_distance, 0.05) << image;
    EXPECT_GT(*m.dice, 0.99) << image;
    EXPECT_EQ(m.self_intersections, 0) << image;
  }
  const std::vector<std::pair<std::string, std::string>> cases2 = {
      {R"({"phantom": "puzzle"})", R"({"phantom": "puzzle", "vertices": 256})"},
      {R"({"phantom": "lung_slice"})", R"({"phantom": "lung_slice", "vertices": 256})"}};
  for (const auto& [image, tmpl] : cases2) {
    const Metrics m = metrics_of_template_at_truth<2>(image, tmpl);
    EXPECT_LT(*m.correspondence_error_max, 1e-9) << image;
    EXPECT_LT(*m.mean_surface_distance, 0.05) << image;
    EXPECT_GT(*m.dice, 0.99) << image;
    EXPECT_EQ(m.self_intersections, 0) << image;
  }
}

TEST(PaperPhantoms, BadKeysAndValuesAreInputErrors) {
  EXPECT_THROW(image_phantom<3>(R"({"phantom": "star", "inner_radius": 40})"), InputError);
  EXPECT_THROW(image_phantom<3>(R"({"phantom": "star", "arms": 5})"), InputError);  // 3D star has no arms
  EXPECT_THROW(template_phantom<3>(R"({"phantom": "star", "subdivisions": 9})"), InputError);
  EXPECT_THROW(image_phantom<3>(R"({"phantom": "tetris", "cell": 0})"), InputError);
  EXPECT_THROW(image_phantom<2>(R"({"phantom": "puzzle", "knob_radius": 20})"), InputError);
  EXPECT_THROW(image_phantom<2>(R"({"phantom": "puzzle", "knob_offset": 9})"), InputError);
  EXPECT_THROW(template_phantom<2>(R"({"phantom": "puzzle", "vertices": 7})"), InputError);
  EXPECT_THROW(template_phantom<3>(R"({"phantom": "c_shape", "bend_deg": 400})"), InputError);
  EXPECT_THROW(template_phantom<3>(R"({"phantom": "bar", "bend_deg": 90})"), InputError);  // only the C bends
  EXPECT_THROW(template_phantom<3>(R"({"phantom": "c_shape", "width": 40})"), InputError);
  EXPECT_THROW(image_phantom<2>(R"({"phantom": "lung_slice", "elongation": 0.9})"), InputError);
  EXPECT_THROW(image_phantom<3>(R"({"phantom": "lung", "rings": 5})"), InputError);  // a template key
  EXPECT_THROW(template_phantom<3>(R"({"phantom": "lung", "bronchi": false})"), InputError);  // an image key
  EXPECT_THROW(template_phantom<3>(R"({"phantom": "lung", "segments": 2})"), InputError);
  EXPECT_THROW(image_phantom<3>(R"({"phantom": "lung", "semi_axes": [1, 0, 1]})"), InputError);
  EXPECT_THROW(image_phantom<3>(R"({"phantom": "bone", "thickness": -1})"), InputError);
  try {
    image_phantom<3>(R"({"phantom": "cube"})");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tetris"), std::string::npos) << e.what();
  }
}

TEST(PaperPhantoms, OlderPhantomsKeepTheirDefaults) {
  // The 2D star is still the 2D star, the 3D sphere still a blurred 64^3 image.
  EXPECT_EQ(image_phantom<2>(R"({"phantom": "star"})").surface.num_vertices(), 10);
  const auto s = image_phantom<3>(R"({"phantom": "sphere", "size": [32, 32, 32], "radius": 10})");
  EXPECT_EQ(s.image.size(), GridIndex<3>(32, 32, 32));
  std::set<float> levels(s.image.data().begin(), s.image.data().end());
  EXPECT_GT(levels.size(), 2u);  // blur 1 by default
  const auto t = template_phantom<3>(R"({"phantom": "sphere"})");
  EXPECT_EQ(t.num_vertices(), 162);
  EXPECT_LT((t.positions[t.landmarks.at("+x")] - Point<3>(31.5 + 24, 31.5, 31.5)).norm(), 1e-9);
}

}  // namespace
}  // namespace dsnake
