// A ground-truth mask on a grid turned against the image's (a label drawn on another
// acquisition, an oblique scan): accepted, resampled along the image's axes, and scored as the
// same object on the image's own grid is.
#include "experiments/spec/experiment.h"
#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "framework/metrics/metrics.h"
#include "tests/energies/edge_images.h"
#include "tests/experiments/temp_dir_test.h"
#include "tests/framework/io_test_support.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <fstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;

// A ball of `radius` about `centre` on `g`: 1 inside, 0 outside.
Image<3> ball_on(const Grid<3>& g, const Point<3>& centre, double radius) {
  Image<3> m(g);
  for (int64_t l = 0; l < m.num_voxels(); ++l) m[l] = (g.to_world(g.to_physical(g.index(l))) - centre).norm() < radius;
  return m;
}

class GroundTruthMaskTest : public TempDirTest {
 protected:
  // The Dice of the template (an icosphere of radius 9 mm about `centre`, 642 vertices) against
  // the truth mask `mask`, with the image a bright ball on an axis-aligned 1 mm grid.
  double start_dice(const Image<3>& mask, const std::string& name) {
    const Point<3> centre(1.0, -2.0, 0.5);
    write_image<3>(radial_image<3>(40, 1.0, [](double r) { return r < 9 ? 200.0 : 50.0; }, 1.0, centre),
                   (dir_ / "image.mha").string());
    write_image<3>(mask, (dir_ / (name + ".mha")).string(), ImageWriteOptions{.label = true});
    Template<3> t = make_icosphere(3);
    for (auto& p : t.positions) p = centre + 9.0 * p;
    write_mesh(t.positions, t.connectivity, (dir_ / "template.off").string());
    nlohmann::ordered_json j = {{"name", name}, {"dimension", 3},
                                {"image", {{"file", "image.mha"}}},
                                {"template", {{"file", "template.off"}}},
                                {"ground_truth", {{"mask", name + ".mha"}}},
                                {"field", {{"type", "gradient"}}},
                                {"energies", {{{"type", "internal"}, {"weight", 1.0}}}},
                                {"phases", {{{"iterations", 1}}}}};
    const fs::path path = dir_ / (name + ".json");
    std::ofstream(path) << j.dump(2);
    Experiment<3> ex = make_experiment<3>(load_experiment_file(path.string()));
    const Snake<3> snake = Snake<3>::from_template(ex.tmpl, ex.initial);
    return compute_metrics<3>(snake, ex.truth).dice.value();
  }
};

TEST_F(GroundTruthMaskTest, AMaskOnATurnedGridScoresAsOnTheImagesAxes) {
  const Point<3> centre(1.0, -2.0, 0.5);
  // The ball on 0.8 mm voxels along the image's axes, and on the same voxels turned 25 degrees
  // about (2, -1, 2) / 3 (which the run resamples onto 0.8 mm voxels along its axes). Thicker
  // voxels would differ by their own staircase, which a grid along other axes does not share; the
  // turned mask's staircase, resampled, differs from the axes' in about one voxel layer in 2 %.
  Grid<3> grid;
  grid.size = {30, 30, 30};
  grid.spacing = {0.8, 0.8, 0.8};
  grid.origin = centre - Point<3>(11.6, 11.6, 11.6);
  const double on_axes = start_dice(ball_on(grid, centre, 9.0), "aligned");
  grid.direction = Eigen::AngleAxisd(0.436, Eigen::Vector3d(2, -1, 2) / 3).toRotationMatrix();
  grid.origin = centre - grid.direction * Point<3>(11.6, 11.6, 11.6);
  const double on_turned = start_dice(ball_on(grid, centre, 9.0), "turned");
  EXPECT_GT(on_axes, 0.97);
  EXPECT_NEAR(on_turned, on_axes, 0.02);
  std::cout << "[ truth mask ] Dice of the same template against the ball on the image's axes " << on_axes
            << ", on a turned grid " << on_turned << "\n";
}

// A mask with no voxel inside (a wrong label map) is refused naming it, instead of scoring the
// result 0 with the distances left empty.
TEST_F(GroundTruthMaskTest, AMaskWithoutAnInsideVoxelIsRefused) {
  Grid<3> grid;
  grid.size = {20, 20, 20};
  grid.origin = Point<3>(-10, -10, -10);
  const InputError e = expect_input_error([&] { start_dice(Image<3>(grid, 0.0f), "empty"); });
  EXPECT_EQ(e.file(), (dir_ / "empty.mha").string());
  EXPECT_TRUE(e.message().find("no voxel is inside") != std::string::npos) << e.what();
}

// A mask whose object lies elsewhere in the world (here 1000 mm along x) is refused naming it and
// the key, as a ground-truth surface there is, instead of scoring every result 0.
TEST_F(GroundTruthMaskTest, AMaskOutsideTheImageIsRefused) {
  Grid<3> grid;
  grid.size = {20, 20, 20};
  grid.origin = Point<3>(990, -10, -10);
  const InputError e = expect_input_error([&] { start_dice(ball_on(grid, Point<3>(1000, 0, 0), 5.0), "far"); });
  EXPECT_EQ(e.file(), (dir_ / "far.mha").string());
  EXPECT_EQ(e.where(), "ground_truth.mask");
  EXPECT_TRUE(e.message().find("lies outside the image") != std::string::npos) << e.what();
  EXPECT_TRUE(e.message().find("along axis 0") != std::string::npos) << e.what();
}

}  // namespace
}  // namespace dsnake
