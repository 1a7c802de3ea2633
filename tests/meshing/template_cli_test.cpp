// `dsnake template` from the command line: a good label gives a readable template and one
// summary line; bad input gives exit code 2, one line on stderr naming the file or option, and
// no output file.
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "tests/experiments/temp_dir_test.h"
#include "tests/meshing/label_test_helpers.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

class TemplateCliTest : public test_support::TempDirTest {
 protected:
  struct Result {
    int exit_code = -1;
    std::string out, err;
  };
  Result dsnake(const std::string& args) {
    const std::string out = (dir_ / "stdout.txt").string(), err = (dir_ / "stderr.txt").string();
    const int status = std::system((std::string(DSNAKE_EXE) + " template " + args + " >" + out + " 2>" + err).c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
  }
  // A 32^3 volume (spacing 1, 1.5, 2; origin 3, -4, 5) with a ball of label 2 (radius 9 voxels
  // of the finest axis) and a bar of label 5 along x touching both x borders.
  fs::path volume() {
    Grid<3> g;
    g.size = GridIndex<3>(32, 28, 24);
    g.spacing = Point<3>(1, 1.5, 2);
    g.origin = Point<3>(3, -4, 5);
    const Point<3> c = g.to_physical(GridIndex<3>(14, 12, 11));
    Image<3> img = test_support::label_image<3>(g, [&](const Point<3>& x) { return (x - c).norm() <= 13; }, 2);
    for (int x = 0; x < 32; ++x)
      for (int y = 1; y <= 3; ++y)
        for (int z = 1; z <= 3; ++z) img.at(GridIndex<3>(x, y, z)) = 5;
    write_image<3>(img, (dir_ / "labels.mha").string());
    return dir_ / "labels.mha";
  }
  fs::path image_2d() {
    Grid<2> g;
    g.size = GridIndex<2>(40, 30);
    Image<2> img = test_support::label_image<2>(g, [](const Point<2>& x) { return (x - Point<2>(20, 15)).norm() <= 9; }, 1);
    write_image<2>(img, (dir_ / "labels2d.mha").string());
    return dir_ / "labels2d.mha";
  }
  // The bad-input contract: exit 2, one line naming every fragment, no output file.
  void expect_refused(const std::string& args, const fs::path& out, const std::vector<std::string>& fragments) {
    const Result r = dsnake(args + " --out " + out.string());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const auto& f : fragments) EXPECT_NE(r.err.find(f), std::string::npos) << "missing \"" << f << "\" in: " << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_EQ(e.path().filename().string().find(out.filename().string() + "."), std::string::npos) << e.path();
  }
};

TEST_F(TemplateCliTest, WritesTheTemplateAndOneSummaryLine) {
  const fs::path labels = volume(), out = dir_ / "ball.off";
  const Result r = dsnake("--mask " + labels.string() + " --label 2 --vertices 500 --mirror y --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  for (const char* f : {"ball.off", "vertices", "genus 0", " 0 self-intersections", "label 2", "mirrored in y"})
    EXPECT_NE(r.out.find(f), std::string::npos) << "missing \"" << f << "\" in: " << r.out;
  const size_t dice_at = r.out.find("Dice ");
  ASSERT_NE(dice_at, std::string::npos) << r.out;
  EXPECT_GE(std::stod(r.out.substr(dice_at + 5)), 0.99) << r.out;
  const Template<3> t = read_mesh_template(out.string());
  EXPECT_LE(std::abs(t.num_vertices() - 500), 50);
  EXPECT_GT(signed_measure<3>(t.positions, t.connectivity), 0);
  // Mirrored in y about the grid's mid-plane (y = -4 + 13.5 * 1.5): the ball's centre at grid
  // y index 12 goes to index 15.
  Point<3> mean = Point<3>::Zero();
  for (const auto& p : t.positions) mean += p;
  mean /= t.num_vertices();
  EXPECT_NEAR(mean.y(), -4 + 15 * 1.5, 0.3);
}

TEST_F(TemplateCliTest, ContourFrom2dLabels) {
  const fs::path labels = image_2d(), out = dir_ / "c.txt";
  const Result r = dsnake("--mask " + labels.string() + " --label 1 --vertices 40 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Template<2> c = read_contour_template(out.string());
  EXPECT_EQ(c.num_vertices(), 40);
  EXPECT_GT(signed_measure<2>(c.positions, c.connectivity), 0);
}

TEST_F(TemplateCliTest, BadInputIsRefusedWithOneLine) {
  const fs::path labels = volume(), out = dir_ / "t.off";
  const std::string m = "--mask " + labels.string();
  expect_refused(m + " --label 7", out, {labels.string(), "label 7", "no voxel has this label", "values present: 0, 2, 5"});
  expect_refused(m + " --label 5", out, {labels.string(), "label 5", "touches the image border"});
  expect_refused(m + " --label 2 --vertices 3", out, {"--vertices 3", "must be in [4, 1000000]"});
  expect_refused(m + " --label 2 --vertices 2000000", out, {"--vertices 2000000"});
  expect_refused(m + " --label 2 --vertices 900000", out, {"--vertices 900000", "more than the"});
  expect_refused(m + " --label 2 --mirror w", out, {"--mirror w", "x, y or z"});
  expect_refused(m + " --label 2", dir_ / "t.png", {"t.png", "--out", "unknown extension"});
  expect_refused("--mask " + (dir_ / "missing.mha").string() + " --label 1", out, {"missing.mha"});
  const fs::path flat = image_2d();
  expect_refused("--mask " + flat.string() + " --label 1 --mirror z", dir_ / "c.txt", {"--mirror z", "x or y"});
  expect_refused("--mask " + flat.string() + " --label 1", out, {"t.off", "unknown extension for a 2D template"});
  // An empty mask (no voxel non-zero) names the file and the label.
  Grid<3> g;
  g.size = GridIndex<3>(8, 8, 8);
  write_image<3>(Image<3>(g, 0.0f), (dir_ / "empty.mha").string());
  expect_refused("--mask " + (dir_ / "empty.mha").string() + " --label 1", out, {"empty.mha", "label 1", "values present: 0"});
}

TEST_F(TemplateCliTest, BorderLabelIsClosedWhenAllowed) {
  const fs::path labels = volume(), out = dir_ / "bar.vtk";
  const Result r = dsnake("--mask " + labels.string() + " --label 5 --vertices 60 --allow-border --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("touches the image border"), std::string::npos) << r.out;
  const Template<3> t = read_mesh_template(out.string());
  EXPECT_EQ(t.connectivity.closed_manifold_problem(), "");
  EXPECT_EQ(t.connectivity.euler_characteristic(), 2);
}

}  // namespace
}  // namespace dsnake
