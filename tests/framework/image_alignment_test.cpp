// NCC image alignment (framework/core/image_alignment.h) on real images with known answers: the
// ITK proton-density brain slice (2D) and Colin27's T1 cut around the basal ganglia (3D),
// resampled by a known rigid, similarity and affine map (a few mm, a few degrees, scale 1.05,
// shear 0.05), also after a linear change of contrast; the alignment recovers the map within
// 0.5 mm at the region's corners and 0.5 deg, by the same steps as without the contrast change
// (variable projection). Invariants: started at the truth it stays there;
// a region that maps outside the moving image keeps the start with a warning; the NCC never
// drops; the same bits on one thread and on two; an oblique reference is aligned in world mm.
#include "framework/core/image_alignment.h"
#include "framework/io/image_io.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <omp.h>

namespace dsnake {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

template <int D>
using Matrix = Eigen::Matrix<double, D, D>;

// x -> c + M (x - c) + t.
template <int D>
AffineMap<D> about(const Point<D>& c, const Matrix<D>& M, const Point<D>& t) {
  AffineMap<D> m;
  m.matrix = M;
  m.translation = c - M * c + t;
  return m;
}

// The moving image of a known answer: S(y) = a R(T^-1 y) + b on R's own grid, so that
// S(T x) = a R(x) + b (linear interpolation, border replicated).
template <int D>
Image<D> resample(const Image<D>& fixed, const AffineMap<D>& T, double a = 1.0, double b = 0.0) {
  const AffineMap<D> inv = T.inverse();
  const Grid<D>& g = fixed.grid();
  Image<D> out(g);
  for (int64_t l = 0; l < out.num_voxels(); ++l) {
    const Point<D> y = g.to_world(g.to_physical(g.index(l)));
    out[l] = float(a * fixed.sample(g.to_frame(inv.apply(y))) + b);
  }
  return out;
}

// The voxels lo..hi of an image (a cut of the large volume, to keep the tests fast).
template <int D>
Image<D> cut(const Image<D>& image, const GridIndex<D>& lo, const GridIndex<D>& hi) {
  Grid<D> g = image.grid();
  g.size = hi - lo + GridIndex<D>::Ones();
  g.origin = image.grid().to_world(image.grid().to_physical(lo));
  Image<D> out(g);
  for (int64_t l = 0; l < out.num_voxels(); ++l) out[l] = image.at(GridIndex<D>(g.index(l) + lo));
  return out;
}

template <int D>
double corner_error(const AffineMap<D>& a, const AffineMap<D>& b, const WorldBox<D>& box) {
  double d = 0;
  for (int k = 0; k < (1 << D); ++k) {
    Point<D> x;
    for (int i = 0; i < D; ++i) x[i] = (k >> i) & 1 ? box.hi[i] : box.lo[i];
    d = std::max(d, (a.apply(x) - b.apply(x)).norm());
  }
  return d;
}

// The angle (deg) between the rotations of two matrices (their polar factors).
template <int D>
double rotation_error_deg(const Matrix<D>& a, const Matrix<D>& b) {
  auto polar = [](const Matrix<D>& m) {
    const Eigen::JacobiSVD<Matrix<D>> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
    return Matrix<D>(svd.matrixU() * svd.matrixV().transpose());
  };
  const Matrix<D> r = polar(a) * polar(b).transpose();
  const double c = std::clamp((r.trace() - (D - 2)) / 2.0, -1.0, 1.0);  // 2D: trace = 2 cos; 3D: 1 + 2 cos
  return std::acos(c) / kDeg;
}

struct Case {
  const char* name;
  AlignmentModel model;
};

class ImageAlignmentTest : public ::testing::Test {
 protected:
  // The ITK slice (221 x 257, 1 mm) and a 60 mm box about its ventricles.
  static const Image<2>& slice() {
    static const Image<2> image = read_image<2>(std::string(DSNAKE_SCANS_DIR) + "/itk/BrainProtonDensitySliceBorder20.mhd");
    return image;
  }
  static WorldBox<2> slice_region() { return {Point<2>(80, 95), Point<2>(140, 155)}; }
  // Colin27 cut to 100 mm about the left basal ganglia, and a 40 mm box there.
  static const Image<3>& colin() {
    static const Image<3> image = [] {
      const std::string path = std::string(DSNAKE_SCANS_DIR) + "/mricron/ch2.nii.gz";
      const Image<3> whole = read_image<3>(path);
      const Point<3> c = centre3();
      const Point<3> ci = whole.grid().to_continuous_index(whole.grid().to_frame(c));
      GridIndex<3> lo, hi;
      for (int a = 0; a < 3; ++a) lo[a] = std::max(0, int(ci[a]) - 50), hi[a] = std::min(whole.size()[a] - 1, int(ci[a]) + 50);
      return cut<3>(whole, lo, hi);
    }();
    return image;
  }
  // The left putamen and pallidum in MNI space (RAS (-22, 2, 2)), in LPS.
  static Point<3> centre3() { return Point<3>(22, -2, 2); }
  static WorldBox<3> colin_region() {
    return {Point<3>(centre3().array() - 20.0), Point<3>(centre3().array() + 20.0)};
  }

  static AffineMap<2> truth2(AlignmentModel m) {
    const Point<2> c = 0.5 * (slice_region().lo + slice_region().hi);
    Matrix<2> M = Eigen::Rotation2Dd(5.0 * kDeg).toRotationMatrix();
    if (m == AlignmentModel::kSimilarity) M *= 1.05;
    if (m == AlignmentModel::kAffine) {
      Matrix<2> s;
      s << 1.05, 0.05, 0.0, 0.97;
      M = M * s;
    }
    return about<2>(c, M, Point<2>(3.0, -2.0));
  }
  static AffineMap<3> truth3(AlignmentModel m) {
    const Point<3> c = centre3();
    Matrix<3> M = Eigen::AngleAxisd(4.0 * kDeg, Point<3>(1, 2, 3).normalized()).toRotationMatrix();
    if (m == AlignmentModel::kSimilarity) M *= 1.05;
    if (m == AlignmentModel::kAffine) {
      Matrix<3> s;
      s << 1.05, 0.05, 0.0, 0.0, 0.97, -0.04, 0.03, 0.0, 1.02;
      M = M * s;
    }
    return about<3>(c, M, Point<3>(3.0, -2.0, 2.5));
  }

  template <int D>
  static void expect_recovered(const ImageAlignmentResult<D>& r, const AffineMap<D>& truth, const WorldBox<D>& region,
                               const std::string& what) {
    const double err = corner_error<D>(r.transform, truth, region);
    const double rot = rotation_error_deg<D>(r.transform.matrix, truth.matrix);
    std::printf("[ measured ] %s: corner error %.3f mm, rotation error %.3f deg, NCC %.4f -> %.4f, %d steps\n",
                what.c_str(), err, rot, r.ncc_before, r.ncc_after, r.iterations);
    EXPECT_TRUE(r.warning.empty()) << what << ": " << r.warning;
    EXPECT_LT(err, 0.5) << what;
    EXPECT_LT(rot, 0.5) << what;
    EXPECT_GT(r.ncc_after, r.ncc_before) << what;
    EXPECT_GT(r.ncc_after, 0.99) << what;
  }
  // Variable projection makes every step invariant under S -> alpha S + beta (the Jacobian's
  // rows a grad S and the span of [S, 1] are unchanged): the same steps and the same map, up to
  // the float rounding of the changed image. A fixed contrast (no projection) takes other steps.
  template <int D>
  static void expect_same_path(const ImageAlignmentResult<D>& a, const ImageAlignmentResult<D>& b, const WorldBox<D>& region,
                               const std::string& what) {
    EXPECT_EQ(a.iterations, b.iterations) << what;
    EXPECT_LT(corner_error<D>(a.transform, b.transform, region), 1e-4) << what;
    EXPECT_NEAR(a.ncc_after, b.ncc_after, 1e-6) << what;
  }
};

const Case kCases[] = {{"rigid", AlignmentModel::kRigid}, {"similarity", AlignmentModel::kSimilarity}, {"affine", AlignmentModel::kAffine}};

TEST_F(ImageAlignmentTest, RecoversKnownMapsOfABrainSlice2d) {
  for (const Case& c : kCases) {
    const AffineMap<2> truth = truth2(c.model);
    ImageAlignmentOptions o;
    o.model = c.model;
    const auto plain = align_images<2>(slice(), resample<2>(slice(), truth), slice_region(), {}, o);
    expect_recovered<2>(plain, truth, slice_region(), std::string("2D ") + c.name);
    // contrast and offset changed: 0.6 I + 40 (the NCC does not see it)
    const auto contrast = align_images<2>(slice(), resample<2>(slice(), truth, 0.6, 40.0), slice_region(), {}, o);
    expect_recovered<2>(contrast, truth, slice_region(), std::string("2D ") + c.name + ", 0.6 I + 40");
    expect_same_path<2>(plain, contrast, slice_region(), c.name);
  }
}

TEST_F(ImageAlignmentTest, RecoversKnownMapsOfColin27BasalGanglia3d) {
  ASSERT_TRUE(std::filesystem::exists(std::string(DSNAKE_SCANS_DIR) + "/mricron/ch2.nii.gz")) << "run scripts/fetch_scans.sh";
  for (const Case& c : kCases) {
    const AffineMap<3> truth = truth3(c.model);
    ImageAlignmentOptions o;
    o.model = c.model;
    const auto plain = align_images<3>(colin(), resample<3>(colin(), truth), colin_region(), {}, o);
    expect_recovered<3>(plain, truth, colin_region(), std::string("3D ") + c.name);
    const auto contrast = align_images<3>(colin(), resample<3>(colin(), truth, 1.7, -25.0), colin_region(), {}, o);
    expect_recovered<3>(contrast, truth, colin_region(), std::string("3D ") + c.name + ", 1.7 I - 25");
    expect_same_path<3>(plain, contrast, colin_region(), c.name);
  }
}

// The model's own parameters only: a rigid model recovers the rotation and translation of a
// rigid truth, but cannot follow a similarity's scale (it stays the closest rigid map).
TEST_F(ImageAlignmentTest, ARigidModelKeepsItsMatrixARotation) {
  ImageAlignmentOptions o;
  o.model = AlignmentModel::kRigid;
  const auto r = align_images<2>(slice(), resample<2>(slice(), truth2(AlignmentModel::kSimilarity)), slice_region(), {}, o);
  EXPECT_NEAR(r.transform.matrix.determinant(), 1.0, 1e-9);
  EXPECT_LT((r.transform.matrix.transpose() * r.transform.matrix - Matrix<2>::Identity()).norm(), 1e-9);
  o.model = AlignmentModel::kSimilarity;
  const auto s = align_images<2>(slice(), resample<2>(slice(), truth2(AlignmentModel::kSimilarity)), slice_region(), {}, o);
  const Matrix<2> m = s.transform.matrix / std::sqrt(s.transform.matrix.determinant());
  EXPECT_LT((m.transpose() * m - Matrix<2>::Identity()).norm(), 1e-9);
  EXPECT_NEAR(std::sqrt(s.transform.matrix.determinant()), 1.05, 0.005);
}

TEST_F(ImageAlignmentTest, StartedAtTheTruthItStaysThere) {
  for (const Case& c : kCases) {
    ImageAlignmentOptions o;
    o.model = c.model;
    const AffineMap<2> t2 = truth2(c.model);
    const auto r2 = align_images<2>(slice(), resample<2>(slice(), t2), slice_region(), t2, o);
    EXPECT_LT(corner_error<2>(r2.transform, t2, slice_region()), 0.1) << c.name;
    EXPECT_GE(r2.ncc_after, r2.ncc_before) << c.name;
    const AffineMap<3> t3 = truth3(c.model);
    const auto r3 = align_images<3>(colin(), resample<3>(colin(), t3), colin_region(), t3, o);
    EXPECT_LT(corner_error<3>(r3.transform, t3, colin_region()), 0.1) << c.name;
    EXPECT_GE(r3.ncc_after, r3.ncc_before) << c.name;
  }
}

// The region mapped 500 mm away from the moving image: the start back, with a warning; and a
// region outside the fixed image likewise.
TEST_F(ImageAlignmentTest, ARegionOutsideAnImageKeepsTheStartWithAWarning) {
  const AffineMap<3> far = about<3>(centre3(), Matrix<3>::Identity(), Point<3>(500, 0, 0));
  const auto r = align_images<3>(colin(), colin(), colin_region(), far, {});
  EXPECT_NE(r.warning.find("outside the moving image"), std::string::npos) << r.warning;
  EXPECT_EQ(r.transform.matrix, far.matrix);
  EXPECT_EQ(r.transform.translation, far.translation);
  const WorldBox<2> away{Point<2>(1000, 1000), Point<2>(1040, 1040)};
  const auto s = align_images<2>(slice(), slice(), away, {}, {});
  EXPECT_NE(s.warning.find("outside the reference image"), std::string::npos) << s.warning;
  EXPECT_EQ(s.transform.matrix, Matrix<2>::Identity());
  // a constant moving image: nothing to align, nothing returned but the start
  const auto flat = align_images<2>(slice(), Image<2>(slice().grid(), 7.0f), slice_region(), {}, {});
  EXPECT_EQ(flat.transform.translation, Point<2>::Zero());
}

// Blocked sums in a fixed order: the same map to the bit on one thread and on two.
TEST_F(ImageAlignmentTest, TheSameBitsForAnyThreadCount) {
  ImageAlignmentOptions o;
  o.model = AlignmentModel::kAffine;
  const AffineMap<3> truth = truth3(AlignmentModel::kAffine);
  const Image<3> moving = resample<3>(colin(), truth);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const auto one = align_images<3>(colin(), moving, colin_region(), {}, o);
  omp_set_num_threads(2);
  const auto two = align_images<3>(colin(), moving, colin_region(), {}, o);
  omp_set_num_threads(threads);
  EXPECT_EQ(one.transform.matrix, two.transform.matrix);
  EXPECT_EQ(one.transform.translation, two.transform.translation);
  EXPECT_EQ(one.ncc_after, two.ncc_after);
}

// An oblique reference (the ITK slice with its axes rotated 30 deg: the same voxels, its world
// image turned about the origin) onto the axis-aligned slice: the map is the inverse rotation,
// found from a start 3 deg and 3 mm off; the grid's direction is taken into account in the
// sampling and in the gradient (world = direction x frame gradient).
TEST_F(ImageAlignmentTest, AnObliqueReferenceIsAlignedInWorldCoordinates2d) {
  const Image<2> oblique = read_image<2>(std::string(DSNAKE_SCANS_DIR) + "/itk/BrainProtonDensitySliceBorder20DirectionPlus30.mhd");
  ASSERT_FALSE(oblique.grid().axis_aligned());
  AffineMap<2> truth;  // fixed world -> moving world: back to the frame
  truth.matrix = oblique.grid().direction.transpose();
  WorldBox<2> region{Point<2>::Constant(1e9), Point<2>::Constant(-1e9)};
  for (const Point<2>& f : {Point<2>(80, 95), Point<2>(140, 95), Point<2>(80, 155), Point<2>(140, 155)}) {
    const Point<2> w = oblique.grid().to_world(f);
    region.lo = region.lo.cwiseMin(w), region.hi = region.hi.cwiseMax(w);
  }
  const Point<2> c = 0.5 * (region.lo + region.hi);
  const AffineMap<2> start = about<2>(c, Eigen::Rotation2Dd(3 * kDeg).toRotationMatrix(), Point<2>(3, -3)).after(truth);
  ImageAlignmentOptions o;
  o.model = AlignmentModel::kRigid;
  const auto r = align_images<2>(oblique, slice(), region, start, o);
  std::printf("[ measured ] oblique reference: %.2f mm off at the start, %.3f mm after\n",
              corner_error<2>(start, truth, region), corner_error<2>(r.transform, truth, region));
  EXPECT_LT(corner_error<2>(r.transform, truth, region), 0.5);
  EXPECT_LT(rotation_error_deg<2>(r.transform.matrix, truth.matrix), 0.5);
}

// The scale bound (max_scale) is relative to the start: a 1.05 similarity is recovered without
// it and with a bound of 1.5, and refused (the start kept, with a warning naming the key) with a
// bound of 1.02; started at that similarity, the result's scale against the start is 1 and kept.
TEST_F(ImageAlignmentTest, AResultScaledBeyondMaxScaleAgainstTheStartKeepsTheStart) {
  const AffineMap<2> truth = truth2(AlignmentModel::kSimilarity);
  const Image<2> moving = resample<2>(slice(), truth);
  ImageAlignmentOptions o;
  o.model = AlignmentModel::kSimilarity;
  for (double bound : {0.0, 1.5}) {
    o.max_scale = bound;
    expect_recovered<2>(align_images<2>(slice(), moving, slice_region(), {}, o), truth, slice_region(),
                        "max_scale " + std::to_string(bound));
  }
  o.max_scale = 1.02;
  const auto refused = align_images<2>(slice(), moving, slice_region(), {}, o);
  EXPECT_NE(refused.warning.find("scale 1.05 is outside [1/1.02, 1.02]"), std::string::npos) << refused.warning;
  EXPECT_EQ(refused.transform.matrix, Matrix<2>::Identity());
  EXPECT_EQ(refused.transform.translation, Point<2>::Zero());
  EXPECT_EQ(refused.ncc_after, refused.ncc_before);
  const auto from_truth = align_images<2>(slice(), moving, slice_region(), truth, o);
  EXPECT_TRUE(from_truth.warning.empty()) << from_truth.warning;
  EXPECT_LT(corner_error<2>(from_truth.transform, truth, slice_region()), 0.1);
}

// For an affine the bound holds along every axis: a map that stretches one direction by 1.12 and
// squashes the other by 1 / 1.12 keeps |det| = 1 (a scale of 1 by the determinant) yet is refused
// with a bound of 1.08, and recovered with 1.5.
TEST_F(ImageAlignmentTest, AnAffineStretchedBeyondMaxScaleAlongOneAxisKeepsTheStart) {
  const Point<2> c = 0.5 * (slice_region().lo + slice_region().hi);
  Matrix<2> m = Eigen::Rotation2Dd(3.0 * kDeg).toRotationMatrix();
  m = m * Eigen::Vector2d(1.12, 1.0 / 1.12).asDiagonal();
  const AffineMap<2> truth = about<2>(c, m, Point<2>(1.0, -1.0));
  const Image<2> moving = resample<2>(slice(), truth);
  ImageAlignmentOptions o;
  o.model = AlignmentModel::kAffine;
  o.max_scale = 1.5;
  expect_recovered<2>(align_images<2>(slice(), moving, slice_region(), {}, o), truth, slice_region(), "stretch 1.12");
  o.max_scale = 1.08;
  const auto refused = align_images<2>(slice(), moving, slice_region(), {}, o);
  EXPECT_NE(refused.warning.find("is outside [1/1.08, 1.08]"), std::string::npos) << refused.warning;
  EXPECT_EQ(refused.transform.matrix, Matrix<2>::Identity());
  EXPECT_EQ(refused.ncc_after, refused.ncc_before);
}

TEST_F(ImageAlignmentTest, BadOptionsAreRefused) {
  ImageAlignmentOptions o;
  o.levels = {};
  EXPECT_THROW(align_images<2>(slice(), slice(), slice_region(), {}, o), std::invalid_argument);
  o.levels = {2.0, -1.0};
  EXPECT_THROW(align_images<2>(slice(), slice(), slice_region(), {}, o), std::invalid_argument);
  o = {};
  o.margin = -1;
  EXPECT_THROW(align_images<2>(slice(), slice(), slice_region(), {}, o), std::invalid_argument);
  EXPECT_THROW(align_images<2>(Image<2>(), slice(), slice_region(), {}, {}), std::invalid_argument);
  o = {};
  o.max_scale = 0.9;  // a bound below 1 would refuse the start itself
  EXPECT_THROW(align_images<2>(slice(), slice(), slice_region(), {}, o), std::invalid_argument);
}

}  // namespace
}  // namespace dsnake
