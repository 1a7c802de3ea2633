#include "experiments/phantoms/corruption.h"
#include "experiments/spec/experiment.h"
#include "experiments/phantoms/phantoms.h"
#include "tests/experiments/phantoms/phantom_test_support.h"
#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <set>

namespace dsnake {
namespace {

template <int D>
Phantom<D> phantom(const std::string& spec) {
  const auto j = nlohmann::json::parse(spec);
  JsonReader r(j, "test", "image");
  auto p = make_phantom<D>(r);
  r.finish();
  return p;
}

template <int D>
double mask_measure(const Image<D>& m) {
  double n = 0;
  for (float v : m.data()) n += v;
  return n * m.spacing().prod();
}

TEST(Phantoms, MasksHaveTheAnalyticAreaAndVolume) {
  EXPECT_NEAR(mask_measure(phantom<2>(R"({"phantom": "disk", "radius": 30})").mask), M_PI * 900, 0.01 * M_PI * 900);
  EXPECT_NEAR(mask_measure(phantom<2>(R"({"phantom": "square", "half_width": 20.3})").mask), 40.6 * 40.6, 0.03 * 1648);
  const auto e = phantom<3>(R"({"phantom": "ellipsoid", "semi_axes": [20, 15, 10], "spacing": [1, 1, 2]})");
  EXPECT_NEAR(mask_measure(e.mask), 4.0 / 3.0 * M_PI * 3000, 0.02 * 4.0 / 3.0 * M_PI * 3000);
  // The star's mask area equals its polygon's area.
  const auto s = phantom<2>(R"({"phantom": "star", "arms": 5, "outer_radius": 40, "inner_radius": 18})");
  const double area = std::abs(signed_measure<2>(s.surface.positions, s.surface.connectivity));
  EXPECT_NEAR(mask_measure(s.mask), area, 0.02 * area);
}

TEST(Phantoms, ImageHasThePapersGreyLevels) {
  const auto d = phantom<2>(R"({"phantom": "disk", "radius": 30, "blur": 0})");
  std::set<float> levels(d.image.data().begin(), d.image.data().end());
  EXPECT_EQ(*levels.begin(), 85.0f);
  EXPECT_EQ(*levels.rbegin(), 170.0f);
}

TEST(Phantoms, UnknownPhantomAndKeysAreErrors) {
  EXPECT_THROW(phantom<2>(R"({"phantom": "triangle"})"), InputError);
  EXPECT_THROW(phantom<2>(R"({"phantom": "disk", "radius": -3})"), InputError);
  EXPECT_THROW(phantom<2>(R"({"phantom": "disk", "radiuss": 3})"), InputError);
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

Image<2> corrupt(const Image<2>& in, const std::string& spec, uint64_t seed) {
  Image<2> img = in;
  const auto j = nlohmann::json::parse(spec);
  JsonReader r(j, "test", "corruption[0]");
  apply_corruption<2>(img, read_corruption(r), seed, 0);
  return img;
}

TEST(Corruption, OutliersFlipTheRequestedFractionAndStayBinary) {
  const auto d = phantom<2>(R"({"phantom": "disk", "radius": 30, "blur": 0, "size": [200, 200]})");
  const Image<2> c = corrupt(d.image, R"({"type": "outliers", "fraction": 0.03})", 7);
  int flipped = 0;
  for (int64_t l = 0; l < c.num_voxels(); ++l) {
    EXPECT_TRUE(c[l] == 85.0f || c[l] == 170.0f);
    flipped += c[l] != d.image[l];
  }
  EXPECT_NEAR(flipped / 40000.0, 0.03, 0.003);
  // Same seed, same image; another seed, another image.
  EXPECT_EQ(corrupt(d.image, R"({"type": "outliers", "fraction": 0.03})", 7).data(), c.data());
  EXPECT_NE(corrupt(d.image, R"({"type": "outliers", "fraction": 0.03})", 8).data(), c.data());
}

TEST(Corruption, NoiseHasTheRequestedSigmaAndIsClamped) {
  Grid<2> g;
  g.size = {200, 200};
  const Image<2> flat(g, 128.0f);
  const Image<2> c = corrupt(flat, R"({"type": "noise", "sigma": 30})", 1);
  double sum = 0, sum2 = 0;
  for (float v : c.data()) {
    sum += v - 128;
    sum2 += (v - 128) * (v - 128);
  }
  EXPECT_NEAR(std::sqrt(sum2 / 40000 - std::pow(sum / 40000, 2)), 30.0, 0.6);
  const Image<2> clamped = corrupt(Image<2>(g, 250.0f), R"({"type": "noise", "sigma": 30})", 1);
  for (float v : clamped.data()) EXPECT_LE(v, 255.0f);
}

TEST(Corruption, PerturbMovesForegroundVoxelsWithinTheRadius) {
  const auto d = phantom<2>(R"({"phantom": "disk", "radius": 20, "blur": 0, "size": [100, 100]})");
  const Image<2> c = corrupt(d.image, R"({"type": "perturb", "radius": 3})", 3);
  for (int64_t l = 0; l < c.num_voxels(); ++l) {
    EXPECT_TRUE(c[l] == 85.0f || c[l] == 170.0f);
    if (c[l] == 85.0f) {  // within r (plus rounding) of the original disk
      const Point<2> x = c.grid().to_physical(c.grid().index(l));
      EXPECT_LT((x - Point<2>(49.5, 49.5)).norm(), 20 + 3 + 0.75);
    }
  }
  EXPECT_NE(c.data(), d.image.data());
}

TEST(ExperimentFile, OverridesReachNestedKeysAndAreValidated) {
  const auto f = builtin_experiment("default", {"energies[0].alpha=0.25", "phases.1.iterations=7", "name=\"x\""});
  EXPECT_EQ(f.document["energies"][0]["alpha"].get<double>(), 0.25);
  EXPECT_EQ(f.document["phases"][1]["iterations"].get<int>(), 7);
  EXPECT_EQ(f.document["name"].get<std::string>(), "x");
  EXPECT_THROW(builtin_experiment("default", {"energies[9].alpha=1"}), InputError);
  EXPECT_THROW(builtin_experiment("default", {"noequals"}), InputError);
  EXPECT_THROW(builtin_experiment("nope"), InputError);
  const auto ex = make_experiment<2>(builtin_experiment("classical", {"template.transform.scale=0.5"}));
  // Scaled about the centroid, then translated by (1.5, -1).
  EXPECT_NEAR((ex.initial[0] - (Point<2>(63.5 + 22 + 1.5, 63.5 - 1.0))).norm(), 0, 1e-9);
  EXPECT_EQ(ex.truth.targets.size(), 64u);
}

TEST(ExperimentFile, SuccessNeedsEveryThreshold) {
  SuccessCriteria s;
  s.dice = 0.9;
  s.mean_surface_distance = 1.0;
  Metrics m;
  m.dice = 0.95;
  EXPECT_FALSE(s.met(m));  // a threshold on a null metric is not met
  m.mean_surface_distance = 0.5;
  EXPECT_TRUE(s.met(m));
  m.dice = 0.8;
  EXPECT_FALSE(s.met(m));
}

TEST(ExperimentFile, FailedThresholdsSayWhichAndByHowMuch) {
  SuccessCriteria s;
  s.hausdorff95 = 2.0;
  s.dice = 0.5;
  Metrics m;
  m.dice = 0.4;
  const auto f = s.failures(m);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_EQ(f[0].metric, "hausdorff95");
  EXPECT_FALSE(f[0].value);
  EXPECT_EQ(f[0].describe(), "hausdorff95 null (needs <= 2)");
  EXPECT_EQ(f[1].describe(), "dice 0.4 < 0.5");
  s.skip_null_metrics = true;  // the defaults skip metrics the truth does not give
  ASSERT_EQ(s.failures(m).size(), 1u);
  m.dice = 0.5;  // at the threshold: met
  EXPECT_TRUE(s.failures(m).empty());
  EXPECT_TRUE(s.met(m));
}

}  // namespace
}  // namespace dsnake
