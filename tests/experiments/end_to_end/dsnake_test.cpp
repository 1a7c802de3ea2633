// A D-Snake end to end from an experiment file: ASAP-MLS with the internal and external
// forces, then the 3D remeshing pipeline, checked against the phantom's ground truth.
#include "experiments/spec/experiment.h"
#include "experiments/output/runner.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

TEST(DSnake, SphereToEllipsoidWithRemeshingFromTheExampleFile) {
  const fs::path out = fs::temp_directory_path() / ("dsnake_example_" + std::to_string(::getpid()));
  fs::remove_all(out);
  auto ex = make_experiment<3>(load_experiment_file(
      std::string(DSNAKE_SOURCE_DIR) + "/experiments/examples/dsnake_sphere_to_ellipsoid.json",
      {"phases[0].iterations=250", "phases[1].iterations=50", "output.figures=false"}));
  const auto r = run_experiment(ex, RunOptions{out.string(), true});
  const auto& m = r["metrics"];
  EXPECT_LT(m["mean_surface_distance"].get<double>(), 1.0);
  EXPECT_GT(m["dice"].get<double>(), 0.9);
  EXPECT_EQ(m["self_intersections"].get<int>(), 0);
  // Refined, yet every template vertex is still there; the mesh stayed a closed sphere.
  EXPECT_EQ(r["vertices"]["deformation"].get<int>(), 162);
  EXPECT_GT(r["vertices"]["final"].get<int>(), 500);
  ASSERT_TRUE(r.contains("mesh_quality"));
  EXPECT_TRUE(r["mesh_quality"]["closed"].get<bool>());
  EXPECT_EQ(r["mesh_quality"]["euler_characteristic"].get<int>(), 2);
  EXPECT_GE(r["mesh_quality"]["share_min_angle_ge_20"].get<double>(), 0.95);
  EXPECT_TRUE(r["phases"][1].contains("mesh_quality"));
  // The collision guard is on by default: its counts per phase and in total.
  ASSERT_TRUE(r.contains("collision_guard"));
  ASSERT_TRUE(r["phases"][1].contains("collision_guard"));
  int64_t checks = 0;
  for (const auto& p : r["phases"]) checks += p["collision_guard"]["checks"].get<int64_t>();
  EXPECT_EQ(r["collision_guard"]["checks"].get<int64_t>(), checks);
  EXPECT_GT(checks, 0);
  for (const char* key : {"shortened", "refused"}) EXPECT_GE(r["collision_guard"][key].get<int64_t>(), 0);
  fs::remove_all(out);
}

TEST(DSnake, TheCollisionGuardCanBeSwitchedOff) {
  const fs::path out = fs::temp_directory_path() / ("dsnake_unguarded_" + std::to_string(::getpid()));
  fs::remove_all(out);
  auto ex = make_experiment<3>(load_experiment_file(
      std::string(DSNAKE_SOURCE_DIR) + "/experiments/examples/dsnake_sphere_to_ellipsoid.json",
      {"phases[0].iterations=250", "phases[1].iterations=10", "output.figures=false", "collision_guard.enabled=false"}));
  const auto r = run_experiment(ex, RunOptions{out.string(), true});
  EXPECT_FALSE(r.contains("collision_guard"));
  EXPECT_FALSE(r["phases"][0].contains("collision_guard"));
  fs::remove_all(out);
}

}  // namespace
}  // namespace dsnake
