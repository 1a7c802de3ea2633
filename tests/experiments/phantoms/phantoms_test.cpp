// The basic phantoms (experiments/phantoms/phantoms.h): masks of the analytic area and volume, the
// paper's grey levels, unknown names and keys refused, correspondence targets on the true shapes.
#include "experiments/phantoms/phantoms.h"
#include "tests/experiments/phantoms/phantom_test_support.h"
#include "framework/core/errors.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <cmath>

namespace dsnake {
namespace {

TEST(Phantoms, MasksHaveTheAnalyticAreaAndVolume) {
  EXPECT_NEAR(mask_measure(image_phantom<2>(R"({"phantom": "disk", "radius": 30})").mask), M_PI * 900, 0.01 * M_PI * 900);
  EXPECT_NEAR(mask_measure(image_phantom<2>(R"({"phantom": "square", "half_width": 20.3})").mask), 40.6 * 40.6, 0.03 * 1648);
  const auto e = image_phantom<3>(R"({"phantom": "ellipsoid", "semi_axes": [20, 15, 10], "spacing": [1, 1, 2]})");
  EXPECT_NEAR(mask_measure(e.mask), 4.0 / 3.0 * M_PI * 3000, 0.02 * 4.0 / 3.0 * M_PI * 3000);
  // The star's mask area equals its polygon's area.
  const auto s = image_phantom<2>(R"({"phantom": "star", "arms": 5, "outer_radius": 40, "inner_radius": 18})");
  const double area = std::abs(signed_measure<2>(s.surface.positions, s.surface.connectivity));
  EXPECT_NEAR(mask_measure(s.mask), area, 0.02 * area);
}

TEST(Phantoms, ImageHasThePapersGreyLevels) {
  const auto d = image_phantom<2>(R"({"phantom": "disk", "radius": 30, "blur": 0})");
  std::set<float> levels(d.image.data().begin(), d.image.data().end());
  EXPECT_EQ(*levels.begin(), 85.0f);
  EXPECT_EQ(*levels.rbegin(), 170.0f);
}

TEST(Phantoms, UnknownPhantomAndKeysAreErrors) {
  EXPECT_THROW(image_phantom<2>(R"({"phantom": "triangle"})"), InputError);
  EXPECT_THROW(image_phantom<2>(R"({"phantom": "disk", "radius": -3})"), InputError);
  EXPECT_THROW(image_phantom<2>(R"({"phantom": "disk", "radiuss": 3})"), InputError);
}

TEST(Phantoms, RadialTargetsLieOnTheTrueBoundary) {
  const auto img = nlohmann::json::parse(R"({"phantom": "square", "half_width": 25, "rotation_deg": 10})");
  const auto tpl = nlohmann::json::parse(R"({"phantom": "circle", "radius": 40, "vertices": 24})");
  JsonReader r(tpl, "t", "template");
  const Template<2> t = make_template_phantom<2>(r);
  const auto targets = targets_of<2>(img, tpl, t);
  ASSERT_EQ(targets.size(), 24u);
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(10 * M_PI / 180).toRotationMatrix();
  for (int k = 0; k < 24; ++k) {
    const Point<2> y = R.transpose() * (*targets[k] - Point<2>(63.5, 63.5));
    EXPECT_NEAR(std::max(std::abs(y.x()), std::abs(y.y())), 25.0, 1e-9);
  }
  const auto ell = nlohmann::json::parse(R"({"phantom": "ellipsoid", "semi_axes": [20, 15, 10]})");
  const auto sph = nlohmann::json::parse(R"({"phantom": "sphere", "subdivisions": 1})");
  JsonReader r3(sph, "t", "template");
  const Template<3> t3 = make_template_phantom<3>(r3);
  for (const auto& x : targets_of<3>(ell, sph, t3))
    EXPECT_NEAR((*x - Point<3>(31.5, 31.5, 31.5)).cwiseQuotient(Point<3>(20, 15, 10)).norm(), 1.0, 1e-9);
}

}  // namespace
}  // namespace dsnake
