// The example field of docs/extending.md (docs/examples/intensity_field.*): one registration
// line, then reading, the enum's names, and forces against hand-computed values on a ramp.
#include "docs/examples/intensity_field.h"
#include "framework/core/errors.h"
#include "framework/core/registry.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace dsnake {
namespace {

TEST(ExtendingExample, IntensityFieldRegistersReadsAndPointsUpTheRamp) {
  Registry<ExternalField<2>> registry;
  registry.add<IntensityField<2>>();
  const auto& schema = registry.entry("intensity").schema_properties;
  EXPECT_EQ(schema["toward"]["enum"], nlohmann::ordered_json({"bright", "dark"}));

  nlohmann::json bad = {{"type", "intensity"}, {"toward", "up"}};
  JsonReader rb(bad, "test.json", "field");
  EXPECT_THROW(registry.read(rb), InputError);

  // I(x, y) = 3 x on a 10 x 6 grid with spacing (2, 1): grad I = (1.5, 0) per mm everywhere,
  // normalised to (1, 0); "dark" flips it.
  Image<2> ramp(Grid<2>{GridIndex<2>(10, 6), Point<2>(2, 1), Point<2>(0, 0)});
  for (int64_t l = 0; l < ramp.num_voxels(); ++l) ramp[l] = 3.0f * ramp.grid().index(l)[0];
  for (const char* toward : {"bright", "dark"}) {
    nlohmann::json spec = {{"type", "intensity"}, {"toward", toward}};
    JsonReader r(spec, "test.json", "field");
    auto field = registry.read(r).build();
    field->compute(ramp);
    const double sign = std::string(toward) == "bright" ? 1.0 : -1.0;
    for (const Point<2>& x : {Point<2>(0, 0), Point<2>(7.3, 2.2), Point<2>(18, 5)}) {
      const Point<2> f = field->force(x, Point<2>::Zero());
      EXPECT_NEAR(f.x(), sign, 1e-6) << toward;
      EXPECT_NEAR(f.y(), 0.0, 1e-12);
    }
    EXPECT_FALSE(field->has_potential());
  }
}

}  // namespace
}  // namespace dsnake
