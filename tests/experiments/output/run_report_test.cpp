// What a run reports about itself: why success is false (result.json's failed_thresholds and
// failure, the last progress line), and the ground truth drawn in its figures when one is given.
#include "experiments/spec/experiment.h"
#include "experiments/output/figures.h"
#include "experiments/output/runner.h"
#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

// Runs a built-in experiment with overrides into `out`, quietly.
template <int D>
nlohmann::ordered_json run_into(const std::string& name, const fs::path& out, const std::vector<std::string>& overrides) {
  auto ex = make_experiment<D>(builtin_experiment(name, overrides));
  return run_experiment(ex, RunOptions{out.string(), true});
}

class RunReport : public test_support::TempDirTest {};

// Pixels of the truth's colour (kTruthCyan, tolerant to antialiasing) in the rows above the
// legend band, and in the whole figure.
struct CyanCount {
  int above_legend = 0, total = 0;
};
CyanCount count_cyan(const fs::path& png) {
  const cv::Mat img = cv::imread(png.string(), cv::IMREAD_COLOR);
  EXPECT_FALSE(img.empty()) << png;
  CyanCount n;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);  // BGR
      if (!(p[0] > 180 && p[1] > 120 && p[2] < 90)) continue;
      ++n.total;
      if (y < img.rows - 40) ++n.above_legend;
    }
  return n;
}

TEST_F(RunReport, FailedThresholdsAreListedWithTheirValues) {
  const fs::path out = dir_ / "thresholds";
  // The default run reaches Dice ~0.99: a threshold of 0.9999 fails, the surface distance passes.
  const auto r = run_into<2>("default", out, {"success={\"dice\": 0.9999, \"mean_surface_distance\": 1.0}"});
  EXPECT_FALSE(r["success"].get<bool>());
  const auto& failed = r["failed_thresholds"];
  ASSERT_EQ(failed.size(), 1u) << failed.dump();
  EXPECT_EQ(failed[0]["metric"], "dice");
  EXPECT_EQ(failed[0]["needs"], ">=");
  EXPECT_DOUBLE_EQ(failed[0]["threshold"].get<double>(), 0.9999);
  EXPECT_DOUBLE_EQ(failed[0]["value"].get<double>(), r["metrics"]["dice"].get<double>());
  const std::string why = r["failure"].get<std::string>();
  EXPECT_NE(why.find("dice 0."), std::string::npos) << why;
  EXPECT_NE(why.find("< 0.9999"), std::string::npos) << why;
  // How each phase ended.
  for (const auto& phase : r["phases"])
    EXPECT_NE(why.find("phase " + phase["name"].get<std::string>() + ": " + phase["status"].get<std::string>()),
              std::string::npos)
        << why;
}

TEST_F(RunReport, ASuccessfulRunHasNoFailure) {
  const fs::path out = dir_ / "success";
  const auto r = run_into<2>("default", out, {});
  EXPECT_TRUE(r["success"].get<bool>());
  EXPECT_TRUE(r["failed_thresholds"].empty());
  EXPECT_TRUE(r["failure"].is_null());
}

// The last progress line says why: "(success: false: dice ... < 0.9999; ...)".
TEST_F(RunReport, TheLastProgressLineSaysWhy) {
  const fs::path out = dir_ / "progress";
  const std::string cmd = std::string(DSNAKE_EXE) + " run builtin:default --set success.dice=0.9999 --out " +
                          out.string() + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string text;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) text.append(buf, n);
  const int status = pclose(p);
  EXPECT_EQ(WEXITSTATUS(status), 0) << text;
  const size_t last = text.rfind("dsnake: wrote ");
  ASSERT_NE(last, std::string::npos) << text;
  const std::string line = text.substr(last, text.find('\n', last) - last);
  EXPECT_NE(line.find("(success: false: dice 0."), std::string::npos) << line;
  EXPECT_NE(line.find("< 0.9999"), std::string::npos) << line;
}

// The truth's outline is in the figures when the run has a ground truth (the phantoms' surface,
// or a mask alone), and the truth's colour appears nowhere when it has none. The runs stop after
// a few iterations, so the result (drawn over the truth) has not reached it.
TEST_F(RunReport, FiguresDrawTheTruthWhenGivenAndOnlyThen) {
  const std::string briefly = "phases=[{\"name\": \"fit\", \"iterations\": 5}]";
  const fs::path with2 = dir_ / "truth2d", with3 = dir_ / "truth3d", without = dir_ / "notruth";
  run_into<2>("default", with2, {"output.image=always", briefly});
  EXPECT_GT(count_cyan(with2 / "overlay.png").above_legend, 1000);  // the square's outline, 64 mm a side
  // The same image as a file, without a ground truth.
  const std::string image = "image={\"file\": \"" + (with2 / "image.nii.gz").string() + "\"}";
  run_into<2>("default", without, {image, briefly});
  EXPECT_EQ(count_cyan(without / "overlay.png").total, 0);
  // A mask alone as the truth (the first run's result mask, near its circle of radius 44), with a
  // smaller circle as the template: the mask's outline.
  const fs::path mask_only = dir_ / "maskonly";
  run_into<2>("default", mask_only,
              {image, "ground_truth={\"mask\": \"" + (with2 / "result_mask.nii.gz").string() + "\"}", briefly,
               "template.radius=20"});
  EXPECT_GT(count_cyan(mask_only / "overlay.png").above_legend, 1000);
  // 3D: the ellipsoid phantom's truth in the three slices.
  run_into<3>("ellipsoid", with3, {briefly});
  EXPECT_GT(count_cyan(with3 / "slices.png").above_legend, 1000);
}

}  // namespace
}  // namespace dsnake
