// Fields on a region of interest (fields/region.h), end to end: a dark disk of contrast 20 next to a
// bright square of contrast 155 (a head MRI's organ and its scalp). Computed on the whole image,
// the edge map is normalised by the square's edges, so the disk's edge is weak and the tension
// shrinks the contour; computed on the template's region (the default) the disk's own edge is
// the strongest, the force at the template is larger, and the disk registers. The region holds
// a fifth of the pixels.
#include "experiments/spec/experiment.h"
#include "experiments/output/runner.h"
#include "framework/io/image_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

class FieldRegionRunTest : public test_support::TempDirTest {
 protected:
  // 200 x 200 pixels of 1 mm: background 100, a disk of radius 30 mm at (60, 60) at 80, the
  // square [140, 190]^2 at 255; the mask of the disk as the ground truth.
  void write_scene() {
    Grid<2> g;
    g.size = GridIndex<2>(200, 200);
    Image<2> image(g, 100.0f), mask(g, 0.0f);
    for (int y = 0; y < 200; ++y)
      for (int x = 0; x < 200; ++x) {
        const GridIndex<2> i(x, y);
        const bool disk = (Point<2>(x, y) - Point<2>(60, 60)).norm() <= 30;
        if (disk) image.at(i) = 80.0f, mask.at(i) = 1.0f;
        if (x >= 140 && x <= 190 && y >= 140 && y <= 190) image.at(i) = 255.0f;
      }
    write_image(image, (dir_ / "scene.mha").string());
    write_image(mask, (dir_ / "disk.mha").string());
  }

  nlohmann::ordered_json run(const std::string& extent) {
    const fs::path file = dir_ / ("region_" + extent + ".json");
    std::ofstream(file) << R"({"name": "region", "dimension": 2,
      "image": {"file": "scene.mha"}, "ground_truth": {"mask": "disk.mha"},
      "template": {"phantom": "circle", "radius": 27, "vertices": 64, "center": [60, 60]},
      "field": {"type": "gvf", "sigma": 1.0, "region": {"extent": ")" << extent << R"("}},
      "energies": [{"type": "internal", "weight": 1.0, "alpha": 0.2},
                   {"type": "external", "weight": 1.0, "tau": 0.5, "normalize": "max"},
                   {"type": "asap_mls", "weight": 0.5, "variant": "approximate", "neighborhood": "rings", "rings": 2}],
      "phases": [{"name": "fit", "iterations": 300, "tolerance": 0.002}]})";
    auto ex = make_experiment<2>(load_experiment_file(file.string(), {}));
    return run_experiment(ex, RunOptions{(dir_ / extent).string(), true});
  }
};

TEST_F(FieldRegionRunTest, TheRegionNormalisesTheEdgeMapAtTheObjectNotAtTheScalp) {
  write_scene();
  const auto region = run("template"), whole = run("whole");
  const double share = region["field_region"]["share_of_image"].get<double>();
  const double at_region = region["external_force"]["median_start_relative"].get<double>();
  const double at_whole = whole["external_force"]["median_start_relative"].get<double>();
  const double dice_region = region["metrics"]["dice"].get<double>(), dice_whole = whole["metrics"]["dice"].get<double>();
  std::printf("  region: %.3f of the image, force at the template %.3f of the largest (whole image: %.3f); Dice %.4f "
              "(whole image: %.4f)\n", share, at_region, at_whole, dice_region, dice_whole);
  // template box 54 mm + 2 x 20 mm margin: 94 x 94 of 200 x 200 pixels
  EXPECT_NEAR(share, 94.0 * 94.0 / 40000.0, 0.01);
  EXPECT_DOUBLE_EQ(whole["field_region"]["share_of_image"].get<double>(), 1.0);
  // measured: 0.631 against 0.490 of the largest force, Dice 0.995 against 0.346 (on the whole
  // image the disk's weak force loses to the tension and the contour shrinks)
  EXPECT_GT(at_region, 1.2 * at_whole);
  EXPECT_GE(dice_region, 0.97);
  EXPECT_LT(dice_whole, dice_region - 0.3);
  EXPECT_EQ(region["metrics"]["self_intersections"].get<int>(), 0);
}

}  // namespace
}  // namespace dsnake
