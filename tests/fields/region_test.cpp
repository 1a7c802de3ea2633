// The field's region of interest (fields/region.h): which voxels it keeps, that cropping moves
// no voxel (a physical point samples the same value in the crop as in the image), and that the
// "region" key reads, validates and names its path.
#include "fields/region.h"

#include "fields/gvf.h"
#include "fields/registry.h"
#include "framework/core/errors.h"
#include "framework/core/json_reader.h"

#include <gtest/gtest.h>

namespace dsnake {
namespace {

Grid<3> grid_3d() {
  Grid<3> g;
  g.size = GridIndex<3>(40, 30, 20);
  g.spacing = Point<3>(0.5, 1.0, 2.0);
  g.origin = Point<3>(-10, 5, 100);
  return g;
}

// The box [0,4] x [10,12] x [110,114] mm widened by max(2, 0.25 x 4) = 2 mm: x from -2 to 6 mm
// (voxels 16..32 at 0.5 mm from -10), y 8..14 (voxels 3..9), z 108..116 (voxels 4..8).
TEST(FieldRegion, KeepsTheVoxelsOfTheWidenedTemplateBox) {
  const PointList<3> points{Point<3>(0, 10, 110), Point<3>(4, 12, 114), Point<3>(2, 11, 112)};
  FieldRegionOptions o;
  o.margin = 2.0;
  const VoxelBox<3> box = region_of_interest(grid_3d(), points, o);
  EXPECT_EQ(box.lo, GridIndex<3>(16, 3, 4));
  EXPECT_EQ(box.size, GridIndex<3>(17, 7, 5));
  // margin_share wins when it is larger: 0.5 x 4 mm = 2 mm with margin 1: the same box
  o.margin = 1.0;
  o.margin_share = 0.5;
  EXPECT_EQ(region_of_interest(grid_3d(), points, o).size, GridIndex<3>(17, 7, 5));
  // clamped to the image, and "whole" is the whole grid
  o.margin = 1000;
  const VoxelBox<3> all = region_of_interest(grid_3d(), points, o);
  EXPECT_EQ(all.lo, GridIndex<3>::Zero());
  EXPECT_EQ(all.size, grid_3d().size);
  o = {};
  o.extent = RegionExtent::kWhole;
  EXPECT_EQ(region_of_interest(grid_3d(), points, o).num_voxels(), grid_3d().num_voxels());
  // a template entirely outside the image still gives a non-empty box at the image's border
  const VoxelBox<3> off = region_of_interest(grid_3d(), PointList<3>{Point<3>(-500, -500, -500)}, FieldRegionOptions{});
  EXPECT_EQ(off.lo, GridIndex<3>::Zero());
  EXPECT_EQ(off.size, GridIndex<3>(1, 1, 1));
}

TEST(FieldRegion, CropMovesNoVoxel) {
  Image<3> image(grid_3d());
  for (int64_t l = 0; l < image.num_voxels(); ++l) image[l] = float(l % 977) * 0.25f;
  const VoxelBox<3> box{GridIndex<3>(5, 7, 3), GridIndex<3>(11, 9, 6)};
  const Image<3> c = crop(image, box);
  EXPECT_EQ(c.size(), box.size);
  EXPECT_EQ(c.spacing(), image.spacing());
  for (int z = 0; z < 6; ++z)
    for (int y = 0; y < 9; ++y)
      for (int x = 0; x < 11; ++x) {
        const GridIndex<3> i(x, y, z);
        ASSERT_EQ(c.at(i), image.at(GridIndex<3>(i + box.lo)));
        ASSERT_EQ(c.grid().to_physical(i), image.grid().to_physical(GridIndex<3>(i + box.lo)));
      }
  const Point<3> inside = c.grid().to_physical(GridIndex<3>(3, 4, 2)) + Point<3>(0.1, 0.3, 0.7);
  EXPECT_DOUBLE_EQ(c.sample(inside), image.sample(inside));
}

TEST(FieldRegion, ReadsTheRegionKeyAndNamesItsPath) {
  const auto read = [](const std::string& text) {
    const nlohmann::json doc = nlohmann::json::parse(text);
    JsonReader r(doc, "exp.json", "field");
    return read_field_spec<2>(r);
  };
  EXPECT_EQ(read(R"({"type": "gvf"})").region.extent, RegionExtent::kTemplate);
  EXPECT_DOUBLE_EQ(read(R"({"type": "gvf"})").region.margin, 20.0);
  const FieldSpec<2> s = read(R"({"type": "gvf", "region": {"extent": "whole", "margin": 5}})");
  EXPECT_EQ(s.region.extent, RegionExtent::kWhole);
  EXPECT_DOUBLE_EQ(s.region.margin, 5.0);
  try {
    read(R"({"type": "gvf", "region": {"margin": -1}})");
    FAIL() << "a negative margin is refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.region.margin"), std::string::npos) << e.what();
  }
  try {
    read(R"({"type": "gvf", "region": {"extent": "box"}})");
    FAIL() << "an unknown extent is refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.region.extent"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dsnake
