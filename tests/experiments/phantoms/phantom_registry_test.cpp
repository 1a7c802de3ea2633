// The phantom families as declared options (experiments/phantoms/phantoms.h): a section is read
// into its family's typed options, unknown keys and out-of-range values are refused naming the
// JSON path and the range, and the schema and the key tables come from the declarations.
#include "experiments/phantoms/phantoms.h"
#include "experiments/phantoms/paper_phantoms.h"
#include "experiments/spec/schema.h"
#include "framework/core/errors.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <set>
#include <string>

namespace dsnake {
namespace {

// The InputError's "where: message" of reading `section` as an experiment's "image" or "template".
template <class Registry>
std::string read_error(const Registry& registry, const std::string& section, const char* path) {
  const auto j = nlohmann::json::parse(section);
  try {
    JsonReader r(j, "exp.json", path);
    registry.read(r);
    r.finish();
  } catch (const InputError& e) {
    return e.where() + ": " + e.message();
  }
  return "";
}

TEST(PhantomRegistry, ASectionIsReadIntoItsFamilysTypedOptions) {
  const auto j = nlohmann::json::parse(R"({"phantom": "puzzle", "half_width": 25, "knob_radius": 6, "size": [96, 80]})");
  JsonReader r(j, "exp.json", "image");
  const auto spec = image_phantoms<2>().read(r);
  r.finish();
  EXPECT_EQ(spec.kind, "puzzle");
  const auto* o = spec.options_as<PuzzleImageOptions>();
  ASSERT_NE(o, nullptr);
  EXPECT_EQ(spec.options_as<DiskOptions>(), nullptr);
  EXPECT_EQ(o->shape.half_width, 25);
  EXPECT_EQ(o->shape.knob_radius, 6);
  EXPECT_EQ(o->shape.knob_offset, 4);  // the default
  EXPECT_EQ(o->canvas.blur, 0);        // the paper's phantoms are binary by default
  // The image is built from those options: 96 x 80 voxels, its centre the default shape centre.
  const Phantom<2> ph = spec.build();
  EXPECT_EQ(ph.image.grid().size, GridIndex<2>(96, 80));
  EXPECT_EQ(o->canvas.center_point(), Point<2>(47.5, 39.5));
}

TEST(PhantomRegistry, AnUnknownKeyIsRefusedNamingItsPath) {
  EXPECT_EQ(read_error(image_phantoms<2>(), R"({"phantom": "disk", "radiuss": 3})", "image"),
            "image.radiuss: unknown key");
  // A key of another family is unknown too: "vertices" is a template's, not an image's.
  EXPECT_EQ(read_error(image_phantoms<2>(), R"({"phantom": "star", "vertices": 30})", "image"),
            "image.vertices: unknown key");
  EXPECT_EQ(read_error(template_phantoms<3>(), R"({"phantom": "star", "arms": 5})", "template"),
            "template.arms: unknown key");
  EXPECT_EQ(read_error(image_phantoms<2>(), R"({"phantom": "triangle"})", "image"),
            "image.phantom: unknown 2D image phantom \"triangle\" (known: disk, square, star, puzzle, lung_slice)");
}

TEST(PhantomRegistry, AnOutOfRangeParameterIsRefusedWithItsRange) {
  EXPECT_EQ(read_error(template_phantoms<2>(), R"({"phantom": "circle", "vertices": 2})", "template"),
            "template.vertices: must be in [3, 100000]");
  EXPECT_EQ(read_error(image_phantoms<2>(), R"({"phantom": "disk", "radius": -3})", "image"), "image.radius: must be > 0");
  EXPECT_EQ(read_error(image_phantoms<3>(), R"({"phantom": "lung", "notch_depth": 0.7})", "image"),
            "image.notch_depth: must be in [0, 0.6]");
  // A point's range holds for every coordinate.
  EXPECT_EQ(read_error(image_phantoms<3>(), R"({"phantom": "ellipsoid", "spacing": [1, 0, 1]})", "image"),
            "image.spacing: must be > 0");
  // Cross-key rules name the key at fault.
  EXPECT_EQ(read_error(image_phantoms<2>(), R"({"phantom": "star", "inner_radius": 50})", "image"),
            "image.inner_radius: must be in (0, outer_radius)");
  EXPECT_EQ(read_error(image_phantoms<2>(), R"({"phantom": "disk", "size": [64]})", "image"),
            "image.size: expected 2 integers");
  EXPECT_EQ(read_error(image_phantoms<3>(), R"({"phantom": "points", "radius": 2})", "image"),
            "image.centers: is required: [[x, y, z], ...]");
  // A wrong type is refused at its path.
  EXPECT_EQ(read_error(template_phantoms<3>(), R"({"phantom": "sphere", "center": [1, 2]})", "template"),
            "template.center: expected 3 numbers");
}

// The schema's phantom variants: one per family and dimension, each with exactly the keys its
// options declare, with their types, units and ranges.
TEST(PhantomRegistry, TheSchemaListsEveryFamilysDeclaredKeys) {
  const auto schema = experiment_schema();
  const auto& variants = schema["$defs"]["experiment"]["properties"]["image"]["anyOf"];
  auto variant = [&](const std::string& kind, const std::string& dims) -> const nlohmann::ordered_json* {
    for (const auto& v : variants)
      if (v["properties"].contains("phantom") && v["properties"]["phantom"]["const"] == kind &&
          v["properties"]["phantom"]["description"].get<std::string>().rfind(dims, 0) == 0)
        return &v;
    return nullptr;
  };
  size_t count = 0;
  for (const auto& [registry_dims, families] :
       {std::pair{std::string("2D"), image_phantoms<2>().names()}, std::pair{std::string("3D"), image_phantoms<3>().names()}})
    for (const auto& kind : families) {
      const auto* v = variant(kind, registry_dims);
      ASSERT_NE(v, nullptr) << registry_dims << " " << kind;
      EXPECT_EQ((*v)["additionalProperties"], false) << kind;
      ++count;
    }
  EXPECT_EQ(count, 13u);  // 5 families in 2D, 8 in 3D
  const auto& lung = (*variant("lung", "3D"))["properties"];
  EXPECT_EQ(lung["notch_depth"]["type"], "number");
  EXPECT_EQ(lung["notch_depth"]["minimum"], 0);
  EXPECT_EQ(lung["notch_depth"]["maximum"], 0.6);
  EXPECT_EQ(lung["bronchus_radius"]["exclusiveMinimum"], 0);
  EXPECT_NE(lung["bronchus_radius"]["description"].get<std::string>().find("[mm]"), std::string::npos);
  EXPECT_EQ(lung["bronchi"]["type"], "boolean");
  EXPECT_EQ(lung["semi_axes"]["minItems"], 3);
  EXPECT_EQ(lung["semi_axes"]["items"]["exclusiveMinimum"], 0);
  EXPECT_EQ(lung["size"]["default"], nlohmann::ordered_json({230, 300, 80}));
  EXPECT_FALSE(lung.contains("vertices"));  // a template key
  const auto& disk = (*variant("disk", "2D"))["properties"];
  EXPECT_EQ(disk["center"]["maxItems"], 2);
  EXPECT_EQ(disk["blur"]["default"], 1.0);
  EXPECT_FALSE(disk.contains("radiuss"));
  // A template family: its own keys and the section's ("transform", "landmarks").
  const auto& templates = schema["$defs"]["experiment"]["properties"]["template"]["anyOf"];
  bool found_c = false;
  for (const auto& v : templates)
    if (v["properties"].contains("phantom") && v["properties"]["phantom"]["const"] == "c_shape") {
      found_c = true;
      EXPECT_EQ(v["properties"]["bend_deg"]["maximum"], 300);
      EXPECT_EQ(v["properties"]["rings"]["type"], "integer");
      EXPECT_TRUE(v["properties"].contains("transform"));
      EXPECT_TRUE(v["properties"].contains("landmarks"));
      EXPECT_FALSE(v["properties"].contains("size"));  // an image's canvas key
    }
  EXPECT_TRUE(found_c);
}

TEST(PhantomRegistry, TheMarkdownHasAKeyTablePerFamily) {
  const std::string md = experiment_reference_markdown();
  for (const auto& kind : template_phantoms<3>().names())
    EXPECT_NE(md.find("#### `template` phantom `" + kind + "` (3D)"), std::string::npos) << kind;
  EXPECT_NE(md.find("| `corner_width_deg` | number | degrees | `30.0` | (0, 180] |"), std::string::npos);
}

}  // namespace
}  // namespace dsnake
