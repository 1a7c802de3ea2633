// Pre-alignment geometry (framework/core/alignment.h): the enclosed moments of a
// polygon and a mesh and the voxel moments of a region against closed forms (a rectangle, a box,
// an oblique grid), the moment alignment recovering a known similarity from a rotated, shifted
// and scaled mask (2D ellipse, 3D ellipsoid), its documented ambiguity and isotropy rules, and
// the point-pair fit exact on exact pairs, least squares on noisy ones, proper on mirrored ones.
#include "framework/core/alignment.h"

#include "experiments/phantoms/phantoms.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace dsnake {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// An ellipse polygon with semi-axes (a, b) about the origin, n vertices counter-clockwise.
PointList<2> ellipse(double a, double b, int n) {
  PointList<2> p;
  for (int i = 0; i < n; ++i) p.push_back(Point<2>(a * std::cos(2 * kPi * i / n), b * std::sin(2 * kPi * i / n)));
  return p;
}

// A closed, outward box mesh [0, a] x [0, b] x [0, c] (12 triangles).
Template<3> box(double a, double b, double c) {
  Template<3> t;
  for (int k = 0; k < 8; ++k) t.positions.push_back(Point<3>(k & 1 ? a : 0, k & 2 ? b : 0, k & 4 ? c : 0));
  t.connectivity = Connectivity::mesh(8, {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                          {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}});
  return t;
}

// A label image on a grid of `spacing` covering [-extent, extent]^D: 1 where inside(x) at the
// voxel centre, else 0.
template <int D>
Image<D> raster(double extent, double spacing, const std::function<bool(const Point<D>&)>& inside) {
  Grid<D> g;
  g.size = GridIndex<D>::Constant(int(std::ceil(2 * extent / spacing)) + 1);
  g.spacing = Point<D>::Constant(spacing);
  g.origin = Point<D>::Constant(-extent);
  Image<D> image(g, 0.0f);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    if (inside(g.to_physical(g.index(l)))) image[l] = 1.0f;
  return image;
}

bool nonzero(float v) { return v != 0.0f; }

TEST(EnclosedMoments, RectangleExactAtAnySamplingAndOrientation) {
  // [1, 7] x [2, 4]: area 12, centroid (4, 3), covariance diag(6^2, 2^2) / 12
  for (int per_side : {1, 25}) {
    PointList<2> p;
    const Point<2> corners[4] = {{1, 2}, {7, 2}, {7, 4}, {1, 4}};
    for (int s = 0; s < 4; ++s)
      for (int k = 0; k < per_side; ++k) p.push_back(corners[s] + (corners[(s + 1) % 4] - corners[s]) * k / per_side);
    for (bool reversed : {false, true}) {
      PointList<2> q = p;
      if (reversed) std::reverse(q.begin(), q.end());
      const Moments<2> m = enclosed_moments<2>(q, Connectivity::polygon(int(q.size())));
      EXPECT_NEAR(m.measure, 12.0, 1e-12);
      EXPECT_NEAR((m.centroid - Point<2>(4, 3)).norm(), 0.0, 1e-12);
      EXPECT_NEAR(m.covariance(0, 0), 3.0, 1e-12);
      EXPECT_NEAR(m.covariance(1, 1), 1.0 / 3.0, 1e-12);
      EXPECT_NEAR(m.covariance(0, 1), 0.0, 1e-12);
    }
  }
}

TEST(EnclosedMoments, BoxMeshExactRotatedAndShifted) {
  const Template<3> b = box(4, 2, 6);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  const Point<3> shift(3, -5, 1);
  PointList<3> p;
  for (const auto& x : b.positions) p.push_back(r * x + shift);
  const Moments<3> m = enclosed_moments<3>(p, b.connectivity);
  EXPECT_NEAR(m.measure, 48.0, 1e-11);
  EXPECT_NEAR((m.centroid - (r * Point<3>(2, 1, 3) + shift)).norm(), 0.0, 1e-12);
  const Eigen::Matrix3d expected = r * Eigen::Vector3d(16.0 / 12, 4.0 / 12, 36.0 / 12).asDiagonal() * r.transpose();
  EXPECT_LT((m.covariance - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(RegionMoments, VoxelBoxesAreExactAndMappedToWorld) {
  // voxels x in {0..5}, y in {0..2} at spacing (0.5, 2): the union of boxes [-0.25, 2.75] x [-1, 5]
  Grid<2> g;
  g.size = GridIndex<2>(8, 5);
  g.spacing = Point<2>(0.5, 2.0);
  g.origin = Point<2>(10, 20);
  g.direction = Eigen::Rotation2Dd(30 * kDeg).toRotationMatrix();  // an oblique grid
  Image<2> mask(g, 0.0f);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 6; ++x) mask.at(GridIndex<2>(x, y)) = 3.0f;
  mask.at(GridIndex<2>(7, 4)) = 1.0f;  // another label
  const Moments<2> m = region_moments<2>(mask, [](float v) { return v == 3.0f; });
  EXPECT_NEAR(m.measure, 18 * 0.5 * 2.0, 1e-12);
  EXPECT_NEAR((m.centroid - g.to_world(Point<2>(10 + 1.25, 20 + 2))).norm(), 0.0, 1e-12);
  const Eigen::Matrix2d frame = Eigen::Vector2d(3.0 * 3.0 / 12, 6.0 * 6.0 / 12).asDiagonal();
  EXPECT_LT((m.covariance - g.direction * frame * g.direction.transpose()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(region_moments<2>(mask, [](float v) { return v == 9.0f; }).measure, 0.0);
}

// The similarity of a 40 x 20 mm ellipse polygon onto a mask of the same ellipse scaled 1.3,
// rotated 35 deg and centred at (6, -4), rasterised at 0.5 mm: recovered within 0.2 deg, 0.3% and
// 0.05 mm (measured: -0.091 deg, +0.02%, 2e-15 mm: the mask is symmetric about its centre).
TEST(AlignMoments, RecoversARotatedShiftedScaledEllipseMask2d) {
  const PointList<2> t = ellipse(20, 10, 400);
  const double scale = 1.3, angle = 35 * kDeg;
  const Point<2> centre(6, -4);
  const Eigen::Matrix2d r = Eigen::Rotation2Dd(angle).toRotationMatrix();
  const Image<2> mask = raster<2>(40, 0.5, [&](const Point<2>& x) {
    const Point<2> y = r.transpose() * (x - centre) / scale;
    return std::pow(y.x() / 20, 2) + std::pow(y.y() / 10, 2) < 1;
  });
  int axes = -1;
  const Similarity<2> s = align_moments<2>(enclosed_moments<2>(t, Connectivity::polygon(400)), region_moments<2>(mask, nonzero), 0.05, &axes);
  EXPECT_EQ(axes, 2);
  EXPECT_NEAR(std::atan2(s.rotation(1, 0), s.rotation(0, 0)) / kDeg, 35.0, 0.2);
  EXPECT_NEAR(s.scale, scale, 0.003 * scale);
  EXPECT_LT((s.translation - centre).norm(), 0.05);
}

// The 3D counterpart: an ellipsoid mesh (semi-axes 16, 11, 7; icosphere 3) onto a mask of it
// scaled 1.2, rotated 50 deg about (1, 2, 3) and centred at (3, -2, 1), rasterised at 0.75 mm:
// within 0.5 deg, 0.5% and 0.1 mm (measured: 0.088 deg, +0.30%, 0.005 mm; the 642-vertex mesh
// inscribed in the ellipsoid encloses a little less than it, so the scale comes out larger).
TEST(AlignMoments, RecoversARotatedShiftedScaledEllipsoidMask3d) {
  Template<3> t = make_icosphere(3);
  const Point<3> axes(16, 11, 7);
  for (auto& p : t.positions) p = p.cwiseProduct(axes);
  const double scale = 1.2;
  const Eigen::Matrix3d r = Eigen::AngleAxisd(50 * kDeg, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Point<3> centre(3, -2, 1);
  const Image<3> mask = raster<3>(24, 0.75, [&](const Point<3>& x) {
    return (r.transpose() * (x - centre) / scale).cwiseQuotient(axes).squaredNorm() < 1;
  });
  int matched = -1;
  const Similarity<3> s = align_moments<3>(enclosed_moments<3>(t.positions, t.connectivity), region_moments<3>(mask, nonzero), 0.05, &matched);
  EXPECT_EQ(matched, 3);
  EXPECT_LT(Eigen::AngleAxisd(s.rotation * r.transpose()).angle() / kDeg, 0.5);
  EXPECT_NEAR(s.scale, scale, 0.005 * scale);
  EXPECT_LT((s.translation - centre).norm(), 0.1);
}

// An ellipse's axes have no sign: of the rotations by 30 and -150 deg that match a template
// turned by -30 deg (equivalently 150 deg) to the target, the one closest to the identity is taken.
TEST(AlignMoments, TheAxisAmbiguityTakesTheRotationClosestToTheIdentity) {
  const Connectivity c = Connectivity::polygon(200);
  for (double turn : {-30.0, 150.0}) {
    PointList<2> t = ellipse(20, 10, 200);
    for (auto& p : t) p = Eigen::Rotation2Dd(turn * kDeg) * p;
    const Similarity<2> s = align_moments<2>(enclosed_moments<2>(t, c), enclosed_moments<2>(ellipse(20, 10, 200), c), 0.05);
    EXPECT_NEAR(std::atan2(s.rotation(1, 0), s.rotation(0, 0)) / kDeg, 30.0, 1e-9) << turn;
    EXPECT_NEAR(s.scale, 1.0, 1e-12);
  }
}

// Near-isotropic shapes leave axes undetermined: a disk keeps the template's orientation; in 3D
// a spheroid's one distinct axis is matched by the smallest rotation.
TEST(AlignMoments, NearIsotropicShapesKeepTheOrientation) {
  const Connectivity c = Connectivity::polygon(200);
  PointList<2> t = ellipse(20, 10, 200), disk = ellipse(15, 15.2, 200);
  int matched = -1;
  Similarity<2> s = align_moments<2>(enclosed_moments<2>(t, c), enclosed_moments<2>(disk, c), 0.05, &matched);
  EXPECT_EQ(matched, 0);
  EXPECT_TRUE(s.rotation.isIdentity(1e-12));
  EXPECT_NEAR(s.scale, std::sqrt(15 * 15.2 / 200.0), 1e-3);

  Template<3> sphere = make_icosphere(3);
  PointList<3> from = sphere.positions, to = sphere.positions;
  const Eigen::Matrix3d r = Eigen::AngleAxisd(40 * kDeg, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  for (auto& p : from) p = p.cwiseProduct(Point<3>(10, 10, 20));
  for (auto& p : to) p = r * p.cwiseProduct(Point<3>(10, 10, 20));
  Similarity<3> s3 = align_moments<3>(enclosed_moments<3>(from, sphere.connectivity), enclosed_moments<3>(to, sphere.connectivity), 0.05, &matched);
  EXPECT_EQ(matched, 1);
  EXPECT_LT((s3.rotation * Point<3>::UnitZ() - r * Point<3>::UnitZ()).norm(), 1e-6);
  EXPECT_NEAR(Eigen::AngleAxisd(s3.rotation).angle() / kDeg, 40.0, 1e-6);  // the smallest such rotation
}

template <int D>
Similarity<D> known_similarity() {
  Similarity<D> s;
  s.scale = 1.7;
  if constexpr (D == 2) s.rotation = Eigen::Rotation2Dd(-63 * kDeg).toRotationMatrix();
  else s.rotation = Eigen::AngleAxisd(110 * kDeg, Eigen::Vector3d(-1, 2, 0.5).normalized()).toRotationMatrix();
  s.translation = Point<D>::LinSpaced(4.0, -6.0);
  return s;
}

template <int D>
double cost(const Similarity<D>& s, const PointList<D>& a, const PointList<D>& b) {
  double e = 0;
  for (size_t i = 0; i < a.size(); ++i) e += (s.apply(a[i]) - b[i]).squaredNorm();
  return e;
}

// Exact pairs under a known similarity: recovered to round-off; noisy pairs (sigma 0.3 mm): the
// fit is a least-squares optimum (every small change of its parameters raises the cost) and near
// the truth; mirrored targets still give a proper rotation.
template <int D>
void fit_similarity_cases() {
  SCOPED_TRACE(std::to_string(D) + "D");
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::uniform_real_distribution<double> u(-20, 20);
  const Similarity<D> truth = known_similarity<D>();
  PointList<D> a, b, noisy;
  for (int i = 0; i < 6; ++i) {
    Point<D> p;
    for (int k = 0; k < D; ++k) p[k] = u(rng);
    a.push_back(p);
    b.push_back(truth.apply(p));
    Point<D> n;
    for (int k = 0; k < D; ++k) n[k] = noise(rng);
    noisy.push_back(b.back() + n);
  }
  ASSERT_EQ(point_pairs_problem<D>(a, b), "");
  const Similarity<D> exact = fit_similarity<D>(a, b, true);
  EXPECT_NEAR(exact.scale, truth.scale, 1e-12);
  EXPECT_LT((exact.rotation - truth.rotation).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((exact.translation - truth.translation).norm(), 1e-10);

  const Similarity<D> fit = fit_similarity<D>(a, noisy, true);
  const double best = cost<D>(fit, a, noisy);
  EXPECT_LT(best, cost<D>(truth, a, noisy));
  for (int k = 0; k < D + 2; ++k)
    for (double h : {-1e-4, 1e-4}) {
      Similarity<D> moved = fit;
      if (k < D) moved.translation[k] += h;
      else if (k == D) moved.scale *= 1 + h;
      else if constexpr (D == 2) moved.rotation = Eigen::Rotation2Dd(h).toRotationMatrix() * fit.rotation;
      else moved.rotation = Eigen::AngleAxisd(h, Eigen::Vector3d(0.3, -1, 0.2).normalized()).toRotationMatrix() * fit.rotation;
      EXPECT_GT(cost<D>(moved, a, noisy), best) << "parameter " << k << " step " << h;
    }
  EXPECT_NEAR(fit.scale, truth.scale, 0.02);
  const Similarity<D> rigid = fit_similarity<D>(a, b, false);
  EXPECT_EQ(rigid.scale, 1.0);
  EXPECT_LT((rigid.rotation - truth.rotation).cwiseAbs().maxCoeff(), 1e-12);  // the rotation of the similarity

  PointList<D> mirrored = b;
  for (auto& p : mirrored) p[0] = -p[0];
  EXPECT_NEAR(fit_similarity<D>(a, mirrored, true).rotation.determinant(), 1.0, 1e-12);
}

TEST(FitSimilarity, ExactOnExactPairsLeastSquaresOnNoisyOnesProperOnMirroredOnes) {
  fit_similarity_cases<2>();
  fit_similarity_cases<3>();
}

TEST(FitSimilarity, TooFewCoincidentAndCollinearPairsAreRefused) {
  const PointList<2> one{Point<2>(1, 2)}, two{Point<2>(1, 2), Point<2>(3, 2)}, same{Point<2>(1, 2), Point<2>(1, 2)};
  EXPECT_EQ(point_pairs_problem<2>(one, one), "needs at least 2 point pairs, found 1");
  EXPECT_EQ(point_pairs_problem<2>(two, two), "");
  EXPECT_EQ(point_pairs_problem<2>(two, same), "the points all coincide");
  const PointList<3> line{Point<3>(0, 0, 0), Point<3>(1, 1, 1), Point<3>(3, 3, 3)},
      plane{Point<3>(0, 0, 0), Point<3>(1, 0, 0), Point<3>(0, 1, 0)};
  EXPECT_EQ(point_pairs_problem<3>(PointList<3>(line.begin(), line.begin() + 2), plane), "needs at least 3 point pairs, found 2");
  EXPECT_EQ(point_pairs_problem<3>(line, plane), "the template's landmarks lie on one line (the rotation about it is undetermined)");
  EXPECT_EQ(point_pairs_problem<3>(plane, line), "the points lie on one line (the rotation about it is undetermined)");
  EXPECT_EQ(point_pairs_problem<3>(plane, plane), "");
}

}  // namespace
}  // namespace dsnake
