// "template.reference_image" end to end: a contour template sitting on the outer edge of a
// ring image (the reference), a target image that is the ring moved by (2, -2) mm with another
// intensity scale; `dsnake run` with the profile energy registers the template onto the moved
// edge. And the problems of the key, named by their JSON path.
#include "experiments/spec/experiment.h"
#include "experiments/output/runner.h"
#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "tests/energies/edge_images.h"
#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>

#include <fstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;

class ReferenceImageTest : public TempDirTest {
 protected:
  // Writes the reference, the target and the template; returns the experiment document.
  nlohmann::ordered_json write_case() {
    const Point<2> shift(2.0, -2.0);
    write_image<2>(radial_image<2>(72, 1.0, dark_ring(8.0, 14.0), 1.0), (dir_ / "reference.mha").string());
    write_image<2>(radial_image<2>(72, 1.0, [](double r) { return 0.4 * (r < 8 ? 200 : r < 14 ? 50 : 200) + 50; }, 1.0, shift),
                   (dir_ / "target.mha").string());
    write_contour(round_template<2>(14.0, Point<2>::Zero(), 40).positions, (dir_ / "template.txt").string());
    write_contour(round_template<2>(14.0, shift, 400).positions, (dir_ / "truth.txt").string());
    nlohmann::ordered_json j = {
        {"name", "reference_profile"}, {"dimension", 2},
        {"image", {{"file", "target.mha"}}},
        {"template", {{"file", "template.txt"}, {"reference_image", "reference.mha"}}},
        {"ground_truth", {{"surface", "truth.txt"}}},
        {"field", {{"type", "gradient"}}},
        {"energies", {{{"type", "internal"}, {"weight", 1.0}, {"alpha", 0.05}},
                      {{"type", "profile"}, {"weight", 4.0}}}},
        {"phases", {{{"iterations", 60}}}},
        {"output", {{"figures", false}, {"result_mask", false}}}};
    return j;
  }
  ExperimentFile file_of(const nlohmann::ordered_json& j) {
    const fs::path path = dir_ / "experiment.json";
    std::ofstream(path) << j.dump(2);
    return load_experiment_file(path.string());
  }
  // The InputError's JSON path when the experiment is made, or "" if it is accepted.
  std::string error_path(const nlohmann::ordered_json& j) {
    try {
      make_experiment<2>(file_of(j));
    } catch (const InputError& e) {
      return e.where();
    }
    return "";
  }
};

// Started 2.8 mm off (the template as read, at the reference's place), the run ends within
// 0.2 mm mean surface distance of the moved edge (blurred: 0.07 mm inside r = 14).
TEST_F(ReferenceImageTest, ProfilesFromTheReferenceRegisterTheMovedTarget) {
  Experiment<2> ex = make_experiment<2>(file_of(write_case()));
  ASSERT_TRUE(ex.reference_image.has_value());
  const auto result = run_experiment(ex, RunOptions{(dir_ / "out").string(), true});
  const double msd = result["metrics"]["mean_surface_distance"].get<double>();
  std::printf("reference image run: mean surface distance %.3f mm, Hausdorff %.3f mm\n", msd,
              result["metrics"]["hausdorff"].get<double>());
  EXPECT_LT(msd, 0.2);
}

TEST_F(ReferenceImageTest, ProblemsNameTheKey) {
  nlohmann::ordered_json j = write_case();
  j["template"]["reference_image"] = "missing.mha";
  EXPECT_EQ(error_path(j), "template.reference_image");
  j["template"]["reference_image"] = 3;
  EXPECT_EQ(error_path(j), "template.reference_image");
  j["template"]["reference_image"] = "";
  EXPECT_EQ(error_path(j), "template.reference_image");
  j = write_case();
  j["solver"] = "global";
  EXPECT_EQ(error_path(j), "energies[1].type");  // the profile force has no least-squares form
  j = write_case();
  j["energies"][1]["polarity"] = "any";
  EXPECT_EQ(error_path(j), "energies[1].polarity");
  // the patch force needs the atlas image: without template.reference_image it is refused
  j = write_case();
  j["energies"][1] = {{"type", "patch"}};
  j["template"].erase("reference_image");
  EXPECT_EQ(error_path(j), "energies[1].type");
  j["energies"][1]["radius"] = -1;
  EXPECT_EQ(error_path(j), "energies[1].radius");
}

}  // namespace
}  // namespace dsnake
