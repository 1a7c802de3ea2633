// `dsnake init`: the file it prints is complete and valid, its lengths follow the image's voxel
// size and the template's edges (init_command.cpp's rules), and run as printed (with the template
// started 10% too small) it registers a label volume it was not tuned for; bad input exits 2
// with one line and prints nothing.
#include "framework/io/image_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

class InitCommandTest : public test_support::TempDirTest {
 protected:
  // Runs dsnake with `args`; returns the exit code, stdout and stderr in out_/err_.
  int dsnake(const std::string& args) {
    const std::string o = (dir_ / "stdout.txt").string(), e = (dir_ / "stderr.txt").string();
    const int status = std::system((std::string(DSNAKE_EXE) + " " + args + " >" + o + " 2>" + e).c_str());
    out_ = slurp(o);
    err_ = slurp(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  // A label volume: 1 inside an ellipsoid (semi-axes 14, 11, 9 mm), anisotropic voxels.
  fs::path ellipsoid_labels() {
    Grid<3> g{GridIndex<3>(44, 36, 26), Point<3>(0.8, 0.8, 1.2), Point<3>(-20, 35, 7)};
    Image<3> im(g, 0.0f);
    const Point<3> c = g.origin + 0.5 * (g.size.cast<double>() - Point<3>::Ones()).cwiseProduct(g.spacing);
    for (int64_t l = 0; l < im.num_voxels(); ++l) {
      const Point<3> d = (g.to_physical(g.index(l)) - c).cwiseQuotient(Point<3>(14, 11, 9));
      im[l] = d.squaredNorm() <= 1 ? 1.0f : 0.0f;
    }
    const fs::path p = dir_ / "labels.nii.gz";
    write_image<3>(im, p.string());
    return p;
  }
  std::string out_, err_;
};

TEST_F(InitCommandTest, PrintsAValidFileWhoseRunRegistersTheVolume) {
  const fs::path labels = ellipsoid_labels(), tmpl = dir_ / "t.off";
  ASSERT_EQ(dsnake("template --mask " + labels.string() + " --label 1 --vertices 400 --out " + tmpl.string()), 0) << err_;
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template " + tmpl.string() + " --mask " + labels.string()), 0)
      << err_;
  const nlohmann::json j = nlohmann::json::parse(out_);
  EXPECT_EQ(j["dimension"], 3);
  EXPECT_TRUE(fs::path(j["image"]["file"].get<std::string>()).is_absolute());
  EXPECT_EQ(j["ground_truth"]["mask"], fs::absolute(labels).string());
  EXPECT_DOUBLE_EQ(j["field"]["sigma"].get<double>(), 1.8);  // 1.5 x the largest spacing, 1.2 mm
  EXPECT_DOUBLE_EQ(j["energies"][1]["tau"].get<double>(), 0.6);  // half a voxel, with normalize max
  EXPECT_EQ(j["energies"][1]["normalize"], "max");
  EXPECT_EQ(j["energies"][2]["type"], "asap_mls");
  EXPECT_DOUBLE_EQ(j["phases"][0]["tolerance"].get<double>(), 0.012);
  const fs::path exp = dir_ / "exp.json";
  std::ofstream(exp) << out_;
  ASSERT_EQ(dsnake("validate " + exp.string()), 0) << err_;

  const fs::path run = dir_ / "run";
  ASSERT_EQ(dsnake("run " + exp.string() + " -o " + run.string() + " -j 2 --quiet --set template.transform.scale=0.9"), 0)
      << err_;
  const nlohmann::json r = nlohmann::json::parse(slurp(run / "result.json"));
  // The start: one iteration with negligible weights.
  const fs::path start = dir_ / "start";
  ASSERT_EQ(dsnake("run " + exp.string() + " -o " + start.string() +
                   " -j 2 --quiet --set template.transform.scale=0.9 --set phases[0].iterations=1"
                   " --set phases[1].iterations=1 --set energies[0].weight=1e-12 --set energies[1].weight=1e-12"
                   " --set energies[2].weight=1e-12"),
            0)
      << err_;
  const nlohmann::json s = nlohmann::json::parse(slurp(start / "result.json"));
  // Started 10% small, the run ends nearer the label's boundary, but not on it. Measured: Dice
  // 0.844 -> 0.872, mean distance 0.897 -> 0.726 mm (0.843 -> 0.871 with the first recipe). Started on the boundary of a larger label
  // (the built-in ellipsoid's), the same settings end about 0.4 mm inside (Dice 0.998 -> 0.953):
  // the recommended settings are not yet good on real labels (issue 20).
  std::printf("  Dice %.3f -> %.3f, mean distance %.3f -> %.3f mm\n", s["metrics"]["dice"].get<double>(),
              r["metrics"]["dice"].get<double>(), s["metrics"]["mean_surface_distance"].get<double>(),
              r["metrics"]["mean_surface_distance"].get<double>());
  EXPECT_GT(r["metrics"]["dice"].get<double>(), s["metrics"]["dice"].get<double>() + 0.015) << s["metrics"].dump();
  EXPECT_LT(r["metrics"]["mean_surface_distance"].get<double>(),
            0.9 * s["metrics"]["mean_surface_distance"].get<double>()) << s["metrics"].dump();
  EXPECT_EQ(r["metrics"]["self_intersections"], 0);
  EXPECT_TRUE(fs::exists(run / "result_mask.nii.gz"));
  EXPECT_FALSE(fs::exists(run / "image.nii.gz"));  // a file read as it is is not copied
}

TEST_F(InitCommandTest, BadInputExitsTwoWithOneLineAndPrintsNothing) {
  const fs::path labels = ellipsoid_labels();
  for (const std::string& args : {"init --image " + labels.string() + " --template " + (dir_ / "missing.off").string(),
                                  "init --image " + (dir_ / "missing.nii").string() + " --template x.off",
                                  "init --image " + labels.string() + " --template " + labels.string()}) {
    SCOPED_TRACE(args);
    EXPECT_EQ(dsnake(args), 2);
    EXPECT_EQ(out_, "");
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
    EXPECT_NE(err_.find("dsnake: error: "), std::string::npos) << err_;
  }
}

}  // namespace
}  // namespace dsnake
