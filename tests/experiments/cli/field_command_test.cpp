// `dsnake field` (experiments/cli/field_command.h): writes the field the registry computes, a PNG
// for 2D images, uses the cache, and names bad parameters.
#include "experiments/cli/field_command.h"
#include "fields/registry.h"
#include "framework/core/errors.h"
#include "framework/io/image_io.h"

#include <filesystem>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

namespace dsnake {
namespace {

std::filesystem::path fresh_dir() {
  const auto dir = std::filesystem::temp_directory_path() / ("dsnake_field_cmd_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

Image<2> disk() {
  Grid<2> grid;
  grid.size = GridIndex<2>(48, 40);
  grid.spacing = Point<2>(1.0, 1.25);
  Image<2> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    image[l] = (grid.to_physical(grid.index(l)) - Point<2>(24, 25)).norm() < 10 ? 200.0f : 50.0f;
  return image;
}

TEST(FieldCommand, WritesTheRegistryFieldAndAFigure) {
  const auto dir = fresh_dir();
  const std::string in = (dir / "disk.mha").string();
  write_image(disk(), in);
  FieldCommandOptions o;
  o.image = in;
  o.type = "gvf";
  o.params = {"mu=0.15", "sigma=1.5", "solver=multigrid"};
  o.out = (dir / "field.mha").string();
  o.cache = (dir / "cache").string();
  ASSERT_EQ(run_field_command(o), 0);
  const VectorField<2> written = read_vector_field<2>(o.out);

  const nlohmann::json spec = nlohmann::json::parse(R"({"type": "gvf", "mu": 0.15, "sigma": 1.5})");
  JsonReader reader(spec, "", "field");
  auto field = field_registry<2>().create(reader);
  field->compute(read_image<2>(in));
  ASSERT_TRUE(written.grid().same_geometry(field->vectors().grid()));
  for (int64_t l = 0; l < written.num_voxels(); ++l)
    ASSERT_LT((written[l] - field->vectors()[l]).norm(), 1e-6) << l;

  const cv::Mat png = cv::imread((dir / "field.png").string());
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, 48 * 11);          // upscaled so that the long (physical) side is >= 512 px
  EXPECT_EQ(png.rows, 40 * 11 * 5 / 4 + kFieldLegendPx);  // physical aspect: y spacing 1.25; the legend below
  // The legend keeps the magnitude: a colour bar from viridis' dark violet (0) to its yellow
  // (|F|max), and the arrows take the bar's colours (none is drawn in the old uniform red).
  const int bar_y = 40 * 11 * 5 / 4 + 8 + 7;
  const cv::Vec3b low = png.at<cv::Vec3b>(bar_y, 13), high = png.at<cv::Vec3b>(bar_y, png.cols - 14);
  EXPECT_GT(low[0], low[1]);   // violet: blue above green
  EXPECT_GT(high[1], high[0]);  // yellow: green above blue
  EXPECT_GT(high[2], 150);
  int yellowish = 0, red = 0;
  for (int y = 0; y < 40 * 11 * 5 / 4; ++y)
    for (int x = 0; x < png.cols; ++x) {
      const cv::Vec3b p = png.at<cv::Vec3b>(y, x);
      yellowish += p[1] > 180 && p[2] > 180 && p[0] < 100;
      red += p[2] > 200 && p[1] < 60 && p[0] < 60;
    }
  EXPECT_GT(yellowish, 10);  // the strongest arrows
  EXPECT_EQ(red, 0);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(o.cache), {}), 1);
  std::filesystem::remove_all(dir);
}

TEST(FieldCommand, BadParametersNameTheKey) {
  const auto dir = fresh_dir();
  const std::string in = (dir / "disk.mha").string();
  write_image(disk(), in);
  FieldCommandOptions o;
  o.image = in;
  o.out = (dir / "f.mha").string();
  o.params = {"mu=0"};
  try {
    run_field_command(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.mu"), std::string::npos) << e.what();
  }
  o.params = {"mu"};
  EXPECT_THROW(run_field_command(o), InputError);
  o.params = {};
  o.type = "vfc";
  o.params = {"radius=500"};
  try {
    run_field_command(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.radius"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(o.out));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dsnake
