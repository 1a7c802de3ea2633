// The star robustness experiments of Levi & Gotsman, D-Snake, §8 (Figs. 13-18), reduced to a
// few seeds per level: experiments/paper/star_dsnake.json and star_gvf_snake.json run through
// the dsnake executable with the same corruption overrides as experiments/paper/star_robustness.json
// and star_beyond.json. Each test asserts the direction of one result of
// REPRODUCTION.md (the star section) (measured there over 10 seeds), so a change in the code that
// reverses a reported result fails here.
#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class StarReproductionTest : public test_support::TempDirTest {
 protected:


  // Runs experiments/paper/<file> on one thread with `corruption` (a JSON list, as in the sweep
  // files), `seed` and the extra --set overrides `sets`; no figures. Returns result.json.
  json run(const std::string& file, const std::string& corruption, int seed, const std::vector<std::string>& sets = {}) {
    const fs::path out = dir_ / ("run" + std::to_string(runs_++));
    const fs::path err = dir_ / "stderr.txt";
    std::string cmd = std::string(DSNAKE_EXE) + " run " + std::string(DSNAKE_SOURCE_DIR) + "/experiments/paper/" + file +
                      " --out " + out.string() + " --quiet -j 1 --set 'corruption=" + corruption + "' --set seed=" +
                      std::to_string(seed) + " --set output.figures=false";
    for (const auto& s : sets) cmd += " --set '" + s + "'";
    cmd += " 2>" + err.string();
    const int status = std::system(cmd.c_str());
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << cmd << "\n" << slurp(err);
    std::ifstream in(out / "result.json");
    if (!in) {
      ADD_FAILURE() << "no result.json: " << cmd;
      return json{{"success", false}, {"metrics", {}}};
    }
    return json::parse(in);
  }

  static bool success(const json& r) { return r.at("success").get<bool>(); }
  static double metric(const json& r, const std::string& key) { return r.at("metrics").at(key).get<double>(); }

  int runs_ = 0;
};

const char* kClean = "[]";
const char* kOutliers1 = R"([{"type":"outliers","fraction":0.01}])";
const char* kOutliers3 = R"([{"type":"outliers","fraction":0.03}])";
const char* kNoise30 = R"([{"type":"noise","sigma":30}])";
const char* kPerturb2 = R"([{"type":"perturb","radius":2}])";
const char* kPerturb4 = R"([{"type":"perturb","radius":4}])";
const char* kPerturb6 = R"([{"type":"perturb","radius":6}])";
const char* kNoise40 = R"([{"type":"noise","sigma":40}])";

// Fig. 14, clean star. D-Snake registers the star (10/10: Dice 0.994, correspondence max 0.30);
// the GVF snake with the paper's alpha 0.5, kappa 0.2 does not reach the arms (Dice
// 0.799, correspondence max 14.1 with the physical internal energy and the collision guard; 0.633 and 20.0 with the
// per-vertex form): the paper's "GVF passes the clean star" does not reproduce.
TEST_F(StarReproductionTest, CleanStarDSnakeRegistersWhereGvfSnakeLosesTheArms) {
  const json ds = run("star_dsnake.json", kClean, 0);
  const json gvf = run("star_gvf_snake.json", kClean, 0);
  EXPECT_TRUE(success(ds));
  EXPECT_GT(metric(ds, "dice"), 0.95);
  EXPECT_LT(metric(ds, "correspondence_error_max"), 1.0);
  EXPECT_FALSE(success(gvf));
  EXPECT_GT(metric(ds, "dice"), metric(gvf, "dice") + 0.15);
  EXPECT_LT(4 * metric(ds, "correspondence_error_max"), metric(gvf, "correspondence_error_max"));
}

// The GVF snake as Xu & Prince run it, its force normalised to unit vectors (the sweep's
// gvf_snake_unit): it reaches further into the arms (Dice 0.897 against 0.799) but the tips stay
// cut flat (HD95 3.88 > 2): still not the paper's Fig. 14.
TEST_F(StarReproductionTest, UnitGvfSnakeReachesFurtherButStillCutsTheArmTips) {
  const json gvf = run("star_gvf_snake.json", kClean, 0);
  const json unit = run("star_gvf_snake.json", kClean, 0, {"energies[1].normalize=unit"});
  EXPECT_FALSE(success(unit));
  EXPECT_GT(metric(unit, "dice"), metric(gvf, "dice") + 0.05);
  EXPECT_GT(metric(unit, "dice"), 0.88);
  EXPECT_GT(metric(unit, "hausdorff95"), 3.0);
  EXPECT_LT(metric(unit, "hausdorff95"), metric(gvf, "hausdorff95"));
}

// Figs. 15-16: 1% outliers. D-Snake passes (10/10), the GVF snake fails (0/10) and ends farther
// from the surface than D-Snake on every seed.
TEST_F(StarReproductionTest, OnePercentOutliersDSnakePassesGvfSnakeFails) {
  for (int seed : {0, 1}) {
    const json ds = run("star_dsnake.json", kOutliers1, seed);
    const json gvf = run("star_gvf_snake.json", kOutliers1, seed);
    EXPECT_TRUE(success(ds)) << "seed " << seed;
    EXPECT_FALSE(success(gvf)) << "seed " << seed;
    EXPECT_LT(metric(ds, "mean_surface_distance"), metric(gvf, "mean_surface_distance")) << "seed " << seed;
    EXPECT_GT(metric(ds, "dice"), metric(gvf, "dice")) << "seed " << seed;
  }
}

// Figs. 17-18: noise sigma 30 and perturbation r 2. The GVF snake fails (mean Dice 0.054 and
// 0.002 over 10 seeds with the per-vertex internal energy; seed 0 with the physical one and the
// collision guard: 0.665 at noise 30); D-Snake keeps the star (mean Dice 0.983 and 0.970, 10/10 each).
TEST_F(StarReproductionTest, NoiseThirtyAndPerturbTwoCollapseTheGvfSnakeNotDSnake) {
  for (const char* level : {kNoise30, kPerturb2}) {
    const json ds = run("star_dsnake.json", level, 0);
    const json gvf = run("star_gvf_snake.json", level, 0);
    EXPECT_TRUE(success(ds)) << level;
    EXPECT_FALSE(success(gvf)) << level;
    EXPECT_GT(metric(ds, "dice"), 0.9) << level;
    EXPECT_LT(metric(gvf, "dice"), metric(ds, "dice") - 0.2) << level;  // noise 30: 0.665 against 0.99
  }
}

// The paper's D-Snake breakdown: it passes 3% outliers (10/10 here, where the paper reports a
// failure) and perturbation r 4 (9/10; the paper: fails) and breaks down at r 6 (2/10).
TEST_F(StarReproductionTest, DSnakePassesThreePercentOutliersAndPerturbFourBreaksDownAtPerturbSix) {
  const double clean_msd = metric(run("star_dsnake.json", kClean, 0), "mean_surface_distance");
  int outlier_successes = 0, perturb4_successes = 0, perturb6_successes = 0;
  double perturb6_msd = 0;
  for (int seed : {0, 1, 2}) {
    outlier_successes += success(run("star_dsnake.json", kOutliers3, seed));
    perturb4_successes += success(run("star_dsnake.json", kPerturb4, seed));
  }
  for (int seed : {0, 2, 3}) {
    const json p = run("star_dsnake.json", kPerturb6, seed);
    perturb6_successes += success(p);
    perturb6_msd += metric(p, "mean_surface_distance") / 3;
  }
  EXPECT_EQ(outlier_successes, 3);
  EXPECT_EQ(perturb4_successes, 3);
  EXPECT_LE(perturb6_successes, 1);
  EXPECT_GT(perturb6_msd, 4 * clean_msd);
}

// Beyond the paper (star_beyond.json): the same D-Snake with the edge map's sigma 2 passes where
// the paper's setting fails: perturbation r 6 (10/10 against 2/10) and noise sigma 40 seed 1.
TEST_F(StarReproductionTest, EdgeMapSigmaTwoPassesWhereThePapersDSnakeFails) {
  const std::vector<std::string> sigma2 = {"field.sigma=2"};
  int paper = 0, beyond = 0;
  for (int seed : {0, 2, 3}) {
    paper += success(run("star_dsnake.json", kPerturb6, seed));
    beyond += success(run("star_dsnake.json", kPerturb6, seed, sigma2));
  }
  paper += success(run("star_dsnake.json", kNoise40, 1));
  beyond += success(run("star_dsnake.json", kNoise40, 1, sigma2));
  EXPECT_EQ(beyond, 4);
  EXPECT_LE(paper, 1);
}

// The start pose: from the template also rotated by (10, -8, 6) deg, the approximate ASAP with
// net_motion "keep" (its proposals carry a net rotation, turned further by the Gauss-Seidel
// order) ends about 8 deg off on the clean star (correspondence max 5.5); with the net rotation
// removed (the default) it ends at 2.4, and the exact variant recovers (1.7). This is
// why star_dsnake.json starts unrotated; star_rotated_pose.json captures such starts.
TEST_F(StarReproductionTest, RotatedStartApproximateAsapStaysRotatedExactRecovers) {
  const std::string rotated = "template.transform.rotation_deg=[10,-8,6]";
  const json kept = run("star_dsnake.json", kClean, 0, {rotated, "energies[2].net_motion=keep"});
  const json approx = run("star_dsnake.json", kClean, 0, {rotated});
  const json exact = run("star_dsnake.json", kClean, 0, {rotated, "energies[2].variant=exact"});
  EXPECT_FALSE(success(kept));
  EXPECT_GT(metric(kept, "correspondence_error_max"), 4.0);
  EXPECT_LT(metric(approx, "correspondence_error_max"), 0.6 * metric(kept, "correspondence_error_max"));
  EXPECT_TRUE(success(exact));
  EXPECT_LT(2 * metric(exact, "correspondence_error_max"), metric(kept, "correspondence_error_max"));
}

}  // namespace
}  // namespace dsnake
