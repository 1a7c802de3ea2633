// VFC: the FFT convolution equals a direct spatial sum on small 2D and 3D images with
// anisotropic spacing; the field points at a disk's edge; a radius larger than the image is a
// configuration error naming field.radius; results do not depend on the thread count.
#include "fields/edge_map.h"
#include "fields/registry.h"
#include "fields/vfc.h"
#include "framework/core/errors.h"

#include <cmath>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <omp.h>

namespace dsnake {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Pseudo-random smooth blobs (deterministic), so the edge map has structure everywhere.
template <int D>
Image<D> blobs(const GridIndex<D>& size, const Point<D>& spacing) {
  Grid<D> grid;
  grid.size = size;
  grid.spacing = spacing;
  Image<D> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const Point<D> x = grid.to_physical(grid.index(l));
    double v = 0;
    for (int a = 0; a < D; ++a) v += std::sin(0.37 * (a + 1) * x[a] + 0.5 * a);
    image[l] = float(v > 0.3 ? 1.0 : 0.0);
  }
  return image;
}

// F(x) = sum_y f(y) k(x - y) dV, directly.
template <int D>
VectorField<D> direct(const VfcField<D>& field, const Image<D>& image) {
  const EdgeMap<D> e = compute_edge_map(image, field.options().edge, false, "vfc");
  const Grid<D>& g = image.grid();
  const double dv = g.spacing.prod();
  VectorField<D> out(g);
  for (int64_t i = 0; i < g.num_voxels(); ++i) {
    Point<D> s = Point<D>::Zero();
    const Point<D> x = g.to_physical(g.index(i));
    for (int64_t j = 0; j < g.num_voxels(); ++j)
      if (e.f[j] != 0) s += double(e.f[j]) * field.kernel(x - g.to_physical(g.index(j))) * dv;
    out[i] = s;
  }
  return out;
}

template <int D>
void expect_matches_direct(const VfcFieldOptions& o, const Image<D>& image) {
  VfcField<D> field(o);
  field.compute(image);
  const VectorField<D> ref = direct(field, image);
  double worst = 0, scale = 0;
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    worst = std::max(worst, (field.vectors()[l] - ref[l]).norm());
    scale = std::max(scale, ref[l].norm());
  }
  ASSERT_GT(scale, 0.0);
  EXPECT_LE(worst, 1e-5 * scale) << "worst " << worst << " scale " << scale;
}

TEST(VfcField, FftEqualsDirectConvolution2d) {
  VfcFieldOptions o;
  o.radius = 9.0;
  o.gamma = 1.7;
  expect_matches_direct<2>(o, blobs<2>(GridIndex<2>(23, 17), Point<2>(1.0, 1.5)));
  o.kernel = VfcKernel::kGaussian;
  o.zeta = 3.0;
  expect_matches_direct<2>(o, blobs<2>(GridIndex<2>(23, 17), Point<2>(1.0, 1.5)));
}

TEST(VfcField, FftEqualsDirectConvolution3d) {
  VfcFieldOptions o;
  o.radius = 6.0;
  expect_matches_direct<3>(o, blobs<3>(GridIndex<3>(13, 11, 7), Point<3>(1.0, 1.0, 2.5)));
}

TEST(VfcField, KernelPointsToItsCentre) {
  VfcFieldOptions o;
  o.radius = 5;
  o.gamma = 2;
  VfcField<2> field(o);
  const Point<2> k = field.kernel(Point<2>(3, 4));
  EXPECT_NEAR(k.x(), -std::pow(5.0 + 1e-8, -2.0) * 0.6, 1e-12);
  EXPECT_NEAR(k.y(), -std::pow(5.0 + 1e-8, -2.0) * 0.8, 1e-12);
  EXPECT_EQ(field.kernel(Point<2>(3, 4.01)), Point<2>::Zero());  // beyond R
  EXPECT_EQ(field.kernel(Point<2>(0, 0)), Point<2>::Zero());
}

// The kernel's half-width floor(radius / spacing) keeps its value for a spacing a rounding
// error above a round one (radius 6, spacing 1 + 2.2e-16: 6 voxels, not 5).
TEST(VfcField, HalfWidthDoesNotDropAtARoundingErrorOfTheSpacing) {
  VfcFieldOptions o;
  o.radius = 6;
  const Image<2> a = blobs<2>(GridIndex<2>(24, 20), Point<2>(1, 1));
  Image<2> b = blobs<2>(GridIndex<2>(24, 20), Point<2>(1.0000000000000002, 1.0000000000000002));
  b.data() = a.data();
  VfcField<2> fa(o), fb(o);
  fa.compute(a);
  fb.compute(b);
  double worst = 0, scale = 0;
  for (int64_t l = 0; l < a.num_voxels(); ++l) {
    worst = std::max(worst, (fa.vectors()[l] - fb.vectors()[l]).norm());
    scale = std::max(scale, fa.vectors()[l].norm());
  }
  ASSERT_GT(scale, 0.0);
  EXPECT_LE(worst, 1e-9 * scale) << "worst " << worst << " scale " << scale;
}

TEST(VfcField, PointsToDiskEdge) {
  Grid<2> grid;
  grid.size = GridIndex<2>(64, 64);
  Image<2> image(grid);
  const Point<2> c(31.7, 32.2);
  for (int64_t l = 0; l < image.num_voxels(); ++l) image[l] = (grid.to_physical(grid.index(l)) - c).norm() < 12;
  VfcFieldOptions o;
  o.radius = 24;
  VfcField<2> field(o);
  field.compute(image);
  for (int k = 0; k < 32; ++k) {
    const Point<2> dir(std::cos(2 * kPi * k / 32), std::sin(2 * kPi * k / 32));
    for (double r : {4.0, 8.0}) EXPECT_GT(field.force(c + r * dir, dir).dot(dir), 0.0) << k << " " << r;
    for (double r : {16.0, 22.0}) EXPECT_LT(field.force(c + r * dir, dir).dot(dir), 0.0) << k << " " << r;
  }
}

TEST(VfcField, RadiusLargerThanImageIsAnError) {
  VfcFieldOptions o;
  o.radius = 40;
  VfcField<2> field(o);
  try {
    field.compute(blobs<2>(GridIndex<2>(30, 20), Point<2>(1, 1)));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.radius"), std::string::npos) << e.what();
  }
}

TEST(VfcField, IndependentOfThreadCountAndReusesPlans) {
  const int threads = omp_get_max_threads();
  const Image<3> image = blobs<3>(GridIndex<3>(40, 36, 20), Point<3>(1, 1, 2));
  VfcFieldOptions o;
  o.radius = 10;
  VfcField<3> one(o), two(o);
  omp_set_num_threads(1);
  one.compute(image);
  omp_set_num_threads(2);
  two.compute(image);
  const VectorField<3> first = two.vectors();
  two.compute(image);  // the same grid: plans and kernel spectra are reused
  EXPECT_EQ(two.timings().kernel_s, 0.0);
  omp_set_num_threads(threads);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    ASSERT_EQ(one.vectors()[l], first[l]) << l;
    ASSERT_EQ(two.vectors()[l], first[l]) << l;
  }
}

TEST(VfcField, RegistryChecksOptions) {
  auto error_of = [](const std::string& text) -> std::string {
    const nlohmann::json j = nlohmann::json::parse(text);
    JsonReader reader(j, "exp.json", "field");
    try {
      field_registry<2>().create(reader);
    } catch (const InputError& e) {
      return e.what();
    }
    return "(no error)";
  };
  EXPECT_EQ(error_of(R"({"type": "vfc", "radius": 20, "kernel": "gaussian", "zeta": 4})"), "(no error)");
  EXPECT_NE(error_of(R"({"type": "vfc", "radius": 0})").find("field.radius"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "vfc", "kernel": "box"})").find("field.kernel"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "vfc", "gamma": 0})").find("field.gamma"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "vfc", "zeta": -1})").find("field.zeta"), std::string::npos);
}

}  // namespace
}  // namespace dsnake
