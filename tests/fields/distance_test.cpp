// Distance field: the transform equals brute force with anisotropic spacing; the potential is
// the distance to the disk's edge, the force points at it with unit length; registry checks.
#include "fields/distance.h"
#include "fields/registry.h"
#include "framework/core/errors.h"

#include <cmath>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace dsnake {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(DistanceTransform, EqualsBruteForce3dAnisotropic) {
  Grid<3> grid;
  grid.size = GridIndex<3>(11, 9, 6);
  grid.spacing = Point<3>(1.0, 0.7, 2.5);
  const int64_t n = grid.num_voxels();
  std::vector<bool> site(n);
  uint32_t state = 12345;
  for (int64_t l = 0; l < n; ++l) {
    state = state * 1664525u + 1013904223u;
    site[l] = (state >> 24) < 8;  // ~3% of voxels
  }
  const std::vector<double> d = squared_distance_transform(grid, site);
  for (int64_t i = 0; i < n; ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (int64_t j = 0; j < n; ++j)
      if (site[j]) best = std::min(best, (grid.to_physical(grid.index(i)) - grid.to_physical(grid.index(j))).squaredNorm());
    ASSERT_NEAR(d[i], best, 1e-9 * std::max(1.0, best)) << i;
  }
}

TEST(DistanceTransform, NoSitesIsInfinite) {
  Grid<2> grid;
  grid.size = GridIndex<2>(4, 3);
  for (double d : squared_distance_transform(grid, std::vector<bool>(12, false))) EXPECT_TRUE(std::isinf(d));
}

TEST(DistanceField, PotentialIsDistanceToDiskEdge) {
  Grid<2> grid;
  grid.size = GridIndex<2>(64, 64);
  Image<2> image(grid);
  const Point<2> c(31.6, 32.3);
  for (int64_t l = 0; l < image.num_voxels(); ++l) image[l] = (grid.to_physical(grid.index(l)) - c).norm() < 15;
  DistanceField<2> field;
  field.compute(image);
  ASSERT_TRUE(field.has_potential());
  for (int k = 0; k < 32; ++k) {
    const Point<2> dir(std::cos(2 * kPi * k / 32), std::sin(2 * kPi * k / 32));
    // The edge voxels form a band about 2 voxels wide around r = 15.
    for (double r : {3.0, 7.0}) {
      EXPECT_NEAR(field.potential(c + r * dir), 15 - r - 1.0, 1.3) << k << " " << r;
      const Point<2> f = field.force(c + r * dir, dir);
      EXPECT_GT(f.dot(dir), 0.85) << k << " " << r;
      EXPECT_NEAR(f.norm(), 1.0, 0.15);  // |grad d| = 1 away from the medial axis
    }
    for (double r : {22.0, 26.0}) {
      EXPECT_NEAR(field.potential(c + r * dir), r - 15 - 1.0, 1.3) << k << " " << r;
      EXPECT_LT(field.force(c + r * dir, dir).dot(dir), -0.85) << k << " " << r;
    }
  }
}

TEST(DistanceField, ConstantImageGivesZero) {
  Grid<3> grid;
  grid.size = GridIndex<3>(5, 5, 5);
  DistanceField<3> field;
  testing::internal::CaptureStderr();
  field.compute(Image<3>(grid, 1.0f));
  EXPECT_NE(testing::internal::GetCapturedStderr().find("warning"), std::string::npos);
  EXPECT_EQ(field.potential(Point<3>(2, 2, 2)), 0.0);
  EXPECT_EQ(field.force(Point<3>(2, 2, 2), Point<3>::Zero()), Point<3>::Zero());
}

TEST(DistanceField, RegistryChecksThreshold) {
  const nlohmann::json j = nlohmann::json::parse(R"({"type": "distance", "threshold": 0})");
  JsonReader reader(j, "exp.json", "field");
  try {
    field_registry<2>().create(reader);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.threshold"), std::string::npos);
  }
}

}  // namespace
}  // namespace dsnake
