#include "framework/core/image.h"
#include "framework/core/image_filters.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace dsnake {
namespace {

template <int D>
Image<D> linear_image(const Grid<D>& g, const Point<D>& a, double b) {
  Image<D> img(g);
  for (int64_t l = 0; l < g.num_voxels(); ++l) img[l] = static_cast<float>(a.dot(g.to_physical(g.index(l))) + b);
  return img;
}

TEST(Image, LinearInterpolationIsExactOnLinearFunctions) {
  Grid<3> g;
  g.size = {7, 5, 4};
  g.spacing = {0.5, 1.5, 2.5};
  g.origin = {-1, 2, 3};
  const Point<3> a(0.3, -0.2, 0.1);
  const Image<3> img = linear_image(g, a, 4.0);
  for (const Point<3>& x : {Point<3>(0.1, 3.3, 5.2), Point<3>(1.9, 7.9, 10.4), Point<3>(-1, 2, 3)})
    EXPECT_NEAR(img.sample(x), a.dot(x) + 4.0, 1e-5);  // float voxels
  Grid<2> g2;
  g2.size = {6, 9};
  g2.spacing = {2.0, 0.5};
  const Image<2> img2 = linear_image<2>(g2, Point<2>(1.0, -3.0), 0.5);
  EXPECT_NEAR(img2.sample(Point<2>(3.3, 1.7)), 3.3 - 5.1 + 0.5, 1e-5);
}

TEST(Image, OutsideTheGridSamplesTheNearestBorderPoint) {
  Grid<2> g;
  g.size = {4, 4};
  const Image<2> img = linear_image<2>(g, Point<2>(1, 10), 0);
  EXPECT_NEAR(img.sample(Point<2>(-5, 1.5)), img.sample(Point<2>(0, 1.5)), 1e-6);
  EXPECT_NEAR(img.sample(Point<2>(2.5, 100)), img.sample(Point<2>(2.5, 3)), 1e-6);
  EXPECT_FALSE(g.inside(Point<2>(-0.1, 1)));
  EXPECT_TRUE(g.inside(Point<2>(3, 3)));
}

// The prefetch hint (the voxels sample() will read) is safe anywhere: on an empty image, outside
// the grid, at non-finite points, on a grid of one voxel per axis; and changes no sample.
TEST(Image, PrefetchIsSafeAnywhereAndChangesNothing) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Point<3>> points = {Point<3>(0.1, 3.3, 5.2), Point<3>(-50, 1e6, 3), Point<3>(nan, 0, nan),
                                        Point<3>(inf, -inf, 0), Point<3>(1e300, -1e300, 1e300)};
  Image<3>().prefetch(points[0]);  // no voxels: nothing to fetch
  Grid<3> g;
  g.size = {7, 5, 4};
  g.spacing = {0.5, 1.5, 2.5};
  g.origin = {-1, 2, 3};
  const Image<3> img = linear_image(g, Point<3>(0.3, -0.2, 0.1), 4.0);
  Grid<3> single;  // one voxel: every step is 0
  single.size = {1, 1, 1};
  const Image<3> one(single, 2.5f);
  std::vector<double> before;
  for (const Point<3>& x : points) before.push_back(img.sample(x));
  for (const Point<3>& x : points) {
    img.prefetch(x);
    one.prefetch(x);
  }
  for (size_t k = 0; k < points.size(); ++k) EXPECT_EQ(img.sample(points[k]), before[k]) << k;
  EXPECT_EQ(one.sample(points[1]), 2.5);
  Grid<2> g2;
  g2.size = {6, 9};
  Image<2>(g2, 1.f).prefetch(Point<2>(nan, 3));
}

TEST(Image, IndexRoundTrip) {
  Grid<3> g;
  g.size = {3, 4, 5};
  for (int64_t l = 0; l < g.num_voxels(); ++l) EXPECT_EQ(g.linear(g.index(l)), l);
  EXPECT_EQ(g.linear(GridIndex<3>(1, 2, 3)), 1 + 3 * (2 + 4 * 3));
}

// A ground truth's mask: made from an image, a voxel is inside where the image is non-zero (the
// metrics' rule for masks given as images: negative, fractional and NaN values count, -0 does
// not), one byte per voxel, on the image's grid; made from bytes, it adopts them.
TEST(BinaryMask, IsInsideWhereTheImageIsNonZero) {
  Grid<2> g;
  g.size = {3, 2};
  g.spacing = {0.5, 2.0};
  g.origin = {1.0, -3.0};
  Image<2> img(g);
  const float values[6] = {0.0f, -0.0f, 1.0f, -2.5f, 1e-30f, std::nanf("")};
  for (int l = 0; l < 6; ++l) img[l] = values[l];
  const BinaryMask<2> mask = img;
  EXPECT_TRUE(mask.grid().same_geometry(g));
  ASSERT_EQ(mask.num_voxels(), 6);
  const bool inside[6] = {false, false, true, true, true, true};
  for (int l = 0; l < 6; ++l) {
    EXPECT_EQ(mask[l], inside[l]) << l;
    EXPECT_EQ(mask.data()[l], inside[l] ? 1 : 0) << l;
    EXPECT_EQ(mask.at(g.index(l)), inside[l]) << l;
  }
  EXPECT_EQ(mask.data().capacity(), 6u);  // a byte per voxel
  std::vector<uint8_t> bytes = {0, 7, 0, 0, 1, 0};
  const uint8_t* storage = bytes.data();
  const BinaryMask<2> adopted(g, std::move(bytes));
  EXPECT_EQ(adopted.data().data(), storage);
  EXPECT_TRUE(adopted[1] && adopted[4] && !adopted[0] && !adopted[5]);
}

// A ball of radius 8 mm on an oblique grid of 0.5 x 0.5 x 1 mm voxels (turned 30 degrees about
// (1, 2, 2) / 3), resampled along the world's axes and along another turn: the same ball, within
// what its voxels resolve (volume, centre, inside and outside well away from its surface).
TEST(BinaryMask, ResampledAlongOtherAxesKeepsItsObjectInWorld) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.5236, Eigen::Vector3d(1, 2, 2) / 3).toRotationMatrix();
  Grid<3> g;
  g.size = {48, 48, 24};
  g.spacing = {0.5, 0.5, 1.0};
  g.origin = {-40.0, 15.0, 7.0};
  g.direction = r;
  const Point<3> centre = g.to_world(g.to_physical(GridIndex<3>(24, 23, 12)));
  std::vector<uint8_t> inside(size_t(g.num_voxels()));
  double volume = 0;
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    inside[size_t(l)] = (g.to_world(g.to_physical(g.index(l))) - centre).norm() < 8.0;
    volume += inside[size_t(l)] * g.spacing.prod();
  }
  const BinaryMask<3> mask(g, std::move(inside));
  for (const Eigen::Matrix3d& axes : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()),
                                      Eigen::Matrix3d(Eigen::AngleAxisd(-1.1, Eigen::Vector3d(0, 0.6, 0.8)).toRotationMatrix())}) {
    const BinaryMask<3> out = resample_along(mask, axes);
    const Grid<3>& o = out.grid();
    EXPECT_LE((o.direction - axes).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_DOUBLE_EQ(o.spacing.minCoeff(), 0.5);  // the mask's finest spacing on every axis
    EXPECT_DOUBLE_EQ(o.spacing.maxCoeff(), 0.5);
    double v = 0;
    Point<3> c = Point<3>::Zero();
    for (int64_t l = 0; l < out.num_voxels(); ++l) {
      const Point<3> x = o.to_world(o.to_physical(o.index(l)));
      const double d = (x - centre).norm();
      if (d < 7.0) {
        EXPECT_TRUE(out[l]) << "inside at " << d << " mm from the centre";
      } else if (d > 9.0) {
        EXPECT_FALSE(out[l]) << "outside at " << d << " mm from the centre";
      }
      v += out[l] * o.spacing.prod();
      c += out[l] * o.spacing.prod() * x;
    }
    EXPECT_NEAR(v / volume, 1.0, 0.02);
    EXPECT_LE((c / v - centre).norm(), 0.05);
    // The grid holds the ball's box and no more: a cube of the box's diagonal at most.
    EXPECT_LE(double(out.num_voxels()) * o.spacing.prod(), std::pow(16.0 * std::sqrt(3.0) + 2.0, 3));
  }
  // Nothing inside: one empty voxel.
  const BinaryMask<3> empty = resample_along(BinaryMask<3>(g, std::vector<uint8_t>(size_t(g.num_voxels()), 0)),
                                             Eigen::Matrix3d(Eigen::Matrix3d::Identity()));
  ASSERT_EQ(empty.num_voxels(), 1);
  EXPECT_FALSE(empty[0]);
}

TEST(VectorField, SamplesEachComponentLinearly) {
  Grid<2> g;
  g.size = {5, 5};
  VectorField<2> f(g);
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    const Point<2> x = g.to_physical(g.index(l));
    f[l] = Point<2>(x.x(), 2 * x.y() + 1);
  }
  EXPECT_NEAR((f.sample(Point<2>(1.25, 3.5)) - Point<2>(1.25, 8.0)).norm(), 0, 1e-12);
  EXPECT_NEAR(f.component(1).sample(Point<2>(0, 2)), 5.0, 1e-6);
}

TEST(ImageFilters, BlurKeepsConstantsAndMassAndIsThreadIndependent) {
  Grid<3> g;
  g.size = {21, 17, 9};
  g.spacing = {1, 1, 2.5};
  Image<3> img(g, 0.0f);
  img.at({10, 8, 4}) = 1000.0f;
  omp_set_num_threads(1);
  const Image<3> b1 = gaussian_blur(img, 2.0);
  omp_set_num_threads(2);
  const Image<3> b2 = gaussian_blur(img, 2.0);
  double mass = 0;
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    EXPECT_EQ(b1[l], b2[l]);
    mass += b1[l];
  }
  EXPECT_NEAR(mass, 1000.0, 1e-2);
  // Spacing-aware: the blur's physical width is the same along x and z.
  EXPECT_NEAR(b1.at({10, 8, 5}) / b1.at({10, 8, 4}), b1.at({10, 8, 4}) > 0 ? std::exp(-2.5 * 2.5 / 8.0) : 0, 0.05);
  const Image<3> c = gaussian_blur(Image<3>(g, 7.0f), 3.0);
  for (int64_t l = 0; l < g.num_voxels(); ++l) EXPECT_NEAR(c[l], 7.0f, 1e-5);
}

// The blur, written per voxel as its comment states (w0 u[i] + w1 (u[i-1] + u[i+1]) + ..., the
// border replicated), against the line-wise implementation: the same bits on every axis, also
// where the support is longer than the axis (the loops are line-wise, the sums in the same order), and
// where a y or z line is wider than the in-place pass's block of 128 columns (131 columns: a
// block of 3 along y, 128 * 4 + 12 along z). Through all three entry points.
TEST(ImageFilters, BlurEqualsThePerVoxelSumBitForBit) {
  for (const int nx : {13, 131}) {
    Grid<3> g;
    g.size = {nx, 4, 9};
    g.spacing = {0.7, 1.3, 2.0};
    Image<3> img(g);
    for (int64_t l = 0; l < g.num_voxels(); ++l) img[l] = static_cast<float>(std::sin(0.37 * l) * 100 + (l % 7));
    const double sigma = 1.9;
    std::vector<double> u(img.data().begin(), img.data().end()), next(u.size());
    for (int a = 0; a < 3; ++a) {
      const double sv = sigma / g.spacing[a];
      const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sv - 1e-9)));
      std::vector<double> w(radius + 1);
      double total = 0;
      for (int k = 0; k <= radius; ++k) total += (k ? 2 : 1) * (w[k] = std::exp(-0.5 * k * k / (sv * sv)));
      for (double& x : w) x /= total;
      for (int64_t l = 0; l < g.num_voxels(); ++l) {
        const GridIndex<3> c = g.index(l);
        auto at = [&](int i) {
          GridIndex<3> d = c;
          d[a] = std::clamp(i, 0, g.size[a] - 1);
          return u[g.linear(d)];
        };
        double sum = w[0] * u[l];
        for (int k = 1; k <= radius; ++k) sum += w[k] * (at(c[a] - k) + at(c[a] + k));
        next[l] = sum;
      }
      u.swap(next);
    }
    for (const int threads : {1, 2}) {
      omp_set_num_threads(threads);
      const Image<3> b = gaussian_blur(img, sigma);
      for (int64_t l = 0; l < g.num_voxels(); ++l) ASSERT_EQ(b[l], static_cast<float>(u[l])) << "voxel " << l;
      const Image<3> moved = gaussian_blur(Image<3>(img), sigma);
      EXPECT_EQ(moved.data(), b.data());
      EXPECT_TRUE(moved.grid().same_geometry(g));
      std::vector<double> d(img.data().begin(), img.data().end());
      gaussian_blur(g, d, sigma);
      EXPECT_EQ(d, u) << nx << " columns, " << threads << " threads";
    }
  }
}

// The run's shared smoothed images: one blur per (image, sigma), the same values as a blur of
// one's own.
// The block average of a linear image on an oblique grid is the same linear function, sampled at
// the coarse grid's voxel centres (world): the blocks' centres are where it says they are; a last
// shorter block averages what it holds; the mean of the whole image is kept when f divides it.
TEST(ImageFilters, BlockAverageOfALinearImageSamplesItAtTheBlocksCentres) {
  Grid<3> g;
  g.size = {10, 7, 6};
  g.spacing = {0.5, 1.0, 1.5};
  g.origin = {3, -2, 7};
  g.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d slope(0.3, -1.1, 0.7);
  Image<3> img(g);
  for (int64_t l = 0; l < g.num_voxels(); ++l) img[l] = float(slope.dot(g.to_world(g.to_physical(g.index(l)))) + 5.0);
  const Image<3> c = block_average<3>(img, GridIndex<3>(2, 3, 1));
  EXPECT_EQ(c.size(), GridIndex<3>(5, 3, 6));
  EXPECT_EQ(c.spacing(), Point<3>(1.0, 3.0, 1.5));
  EXPECT_TRUE(c.grid().direction.isApprox(g.direction));
  for (int64_t k = 0; k < c.num_voxels(); ++k) {
    const GridIndex<3> i = c.grid().index(k);
    if (i[1] == 2) {  // the last block along y holds one voxel (y = 6): its value
      EXPECT_NEAR(c[k], img.at(GridIndex<3>(2 * i[0], 6, i[2])) * 0.5 + img.at(GridIndex<3>(2 * i[0] + 1, 6, i[2])) * 0.5, 1e-4);
      continue;
    }
    EXPECT_NEAR(c[k], slope.dot(c.grid().to_world(c.grid().to_physical(i))) + 5.0, 1e-4) << k;
  }
  const Image<3> same = block_average<3>(img, GridIndex<3>(1, 1, 1));
  EXPECT_EQ(same.data(), img.data());
  EXPECT_TRUE(same.grid().same_geometry(g));
}

TEST(ImageFilters, SmoothedImageCacheSmoothsEachImageAndSigmaOnce) {
  Grid<2> g;
  g.size = {20, 12};
  Image<2> a(g, 0.0f), b(g, 0.0f);
  a.at({5, 6}) = 10.0f;
  b.at({14, 3}) = 4.0f;
  SmoothedImageCache<2> cache;
  const auto a1 = cache.get(a, 1.0), a1_again = cache.get(a, 1.0), a2 = cache.get(a, 2.0), b1 = cache.get(b, 1.0);
  EXPECT_EQ(a1.get(), a1_again.get());
  EXPECT_NE(a1.get(), a2.get());
  EXPECT_NE(a1.get(), b1.get());
  EXPECT_EQ(a1->data(), gaussian_blur(a, 1.0).data());
  EXPECT_EQ(a2->data(), gaussian_blur(a, 2.0).data());
  EXPECT_EQ(b1->data(), gaussian_blur(b, 1.0).data());
  EXPECT_EQ(cache.get(a, 0.0)->data(), a.data());  // sigma 0: a copy
}

// A spacing a rounding error off 1 (as a NRRD reader computes it, the norm of a rotated space
// direction: 1 - 2.2e-16) gives the blur of spacing 1: the 3-sigma support does not jump from 3
// to 4 voxels (which changed the blur by ~1e-4 and an oblique scan's registration by 2.6e-4 mm).
TEST(ImageFilters, BlurSupportDoesNotJumpAtARoundingErrorOfTheSpacing) {
  Grid<2> g;
  g.size = {15, 1};
  Image<2> img(g, 0.0f);
  img.at({7, 0}) = 1.0f;
  const Image<2> b1 = gaussian_blur(img, 1.0);
  for (const double h : {0.99999999999999978, 1.0000000000000002}) {
    Grid<2> gh = g;
    gh.spacing = {h, h};
    Image<2> imgh(gh, 0.0f);
    imgh.data() = img.data();
    const Image<2> bh = gaussian_blur(imgh, 1.0);
    for (int64_t l = 0; l < g.num_voxels(); ++l) EXPECT_NEAR(bh[l], b1[l], 1e-12) << h << " voxel " << l;
  }
  EXPECT_EQ(b1.at({3, 0}), 0.0f);  // support 3 voxels at spacing 1
  EXPECT_GT(b1.at({4, 0}), 0.0f);
}

TEST(ImageFilters, GradientOfALinearImageIsItsSlope) {
  Grid<3> g;
  g.size = {6, 7, 8};
  g.spacing = {0.5, 1.0, 3.0};
  const Image<3> img = linear_image<3>(g, Point<3>(2, -1, 0.5), 3);
  const VectorField<3> grad = gradient(img);
  for (int64_t l = 0; l < g.num_voxels(); ++l) EXPECT_NEAR((grad[l] - Point<3>(2, -1, 0.5)).norm(), 0, 1e-4);
}

// partial_derivative_at (the row loops' form, no divisions) gives partial_derivative's bits at
// every voxel, borders and single-voxel axes included, on doubles and on floats; and the
// one-sided and central differences have their hand-computed values.
TEST(ImageFilters, PartialDerivativeAtEqualsPartialDerivativeBitForBit) {
  Grid<3> g;
  g.size = {5, 1, 3};
  g.spacing = {0.5, 2.0, 3.0};
  std::vector<double> u(g.num_voxels());
  for (size_t l = 0; l < u.size(); ++l) u[l] = std::sin(0.7 * double(l) + 0.3) * (1 + double(l) * double(l));
  const std::vector<float> uf(u.begin(), u.end());
  int64_t stride[3] = {1, 5, 5};
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    const GridIndex<3> i = g.index(l);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(partial_derivative_at(u.data(), l, stride[a], i[a], g.size[a], g.spacing[a]),
                partial_derivative(g, u, l, a)) << l << " " << a;
      EXPECT_EQ(partial_derivative_at(uf.data(), l, stride[a], i[a], g.size[a], g.spacing[a]),
                partial_derivative(g, uf, l, a)) << l << " " << a;
    }
  }
  const double v[3] = {1.0, 4.0, 2.0};  // along x at spacing 0.5: one-sided 6 and -4, central 1
  EXPECT_EQ(partial_derivative_at(v, 0, 1, 0, 3, 0.5), 6.0);
  EXPECT_EQ(partial_derivative_at(v, 1, 1, 1, 3, 0.5), 1.0);
  EXPECT_EQ(partial_derivative_at(v, 2, 1, 2, 3, 0.5), -4.0);
  EXPECT_EQ(partial_derivative_at(v, 0, 1, 0, 1, 0.5), 0.0);  // a single-voxel axis
}

// sample_lattice() gives sample()'s values bit for bit, inside the grid, across its border
// (clamped) and for a step that is not the voxel size, in 2D and 3D.
template <int D>
void lattice_matches_sample() {
  Grid<D> g;
  for (int a = 0; a < D; ++a) g.size[a] = 7 + 2 * a;
  g.spacing = Point<D>::Constant(0.8);
  g.spacing[0] = 1.1;
  g.origin = Point<D>::Constant(-2.0);
  Image<D> image(g);
  for (int64_t l = 0; l < image.num_voxels(); ++l) image[l] = static_cast<float>(std::sin(0.37 * l) * 50 + l % 7);
  for (double h : {1.0, 0.63}) {
    for (const Point<D>& x : {Point<D>(Point<D>::Constant(0.3)), Point<D>(Point<D>::Constant(-2.9)), Point<D>(Point<D>::Constant(5.2))}) {
      const int half = 3, w = 2 * half + 1;
      int total = 1;
      for (int a = 0; a < D; ++a) total *= w;
      std::vector<double> out(total);
      image.sample_lattice(x, h, half, out.data());
      for (int k = 0; k < total; ++k) {
        Point<D> o;
        int r = k;
        for (int a = 0; a < D; ++a) {
          o[a] = double(r % w - half);
          r /= w;
        }
        EXPECT_EQ(out[k], image.sample(x + h * o));
      }
    }
  }
}
TEST(Image, SampleLatticeEqualsSampleBitForBit2D) { lattice_matches_sample<2>(); }
TEST(Image, SampleLatticeEqualsSampleBitForBit3D) { lattice_matches_sample<3>(); }

}  // namespace
}  // namespace dsnake
