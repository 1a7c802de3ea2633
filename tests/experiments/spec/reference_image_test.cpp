// "template.reference_image" end to end: a contour template sitting on the outer edge of a
// ring image (the reference), a target image that is the ring moved by (2, -2) mm with another
// intensity scale; `dsnake run` with the profile energy registers the template onto the moved
// edge. And the problems of the key, named by their JSON path.
#include "experiments/output/runner.h"
#include "tests/experiments/spec/ring_case_test.h"

#include <gtest/gtest.h>

namespace dsnake {
namespace {

using namespace test_support;

class ReferenceImageTest : public RingCaseTest {
 protected:
  nlohmann::ordered_json write_case() { return write_ring_case("reference_profile"); }
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
