#include "experiments/spec/experiment.h"
#include "experiments/phantoms/phantoms.h"
#include "framework/core/errors.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>

namespace dsnake {
namespace {

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
