// The corruptions (experiments/phantoms/corruption.h): outliers, noise and perturbation as asked,
// reproducible from their seed.
#include "experiments/phantoms/corruption.h"
#include "tests/experiments/phantoms/phantom_test_support.h"
#include "framework/core/errors.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>

namespace dsnake {
namespace {

Image<2> corrupt(const Image<2>& in, const std::string& spec, uint64_t seed) {
  Image<2> img = in;
  const auto j = nlohmann::json::parse(spec);
  JsonReader r(j, "test", "corruption[0]");
  apply_corruption<2>(img, read_corruption(r), seed, 0);
  return img;
}

TEST(Corruption, OutliersFlipTheRequestedFractionAndStayBinary) {
  const auto d = image_phantom<2>(R"({"phantom": "disk", "radius": 30, "blur": 0, "size": [200, 200]})");
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
  const auto d = image_phantom<2>(R"({"phantom": "disk", "radius": 20, "blur": 0, "size": [100, 100]})");
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

}  // namespace
}  // namespace dsnake
