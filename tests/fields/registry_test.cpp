// The field registry: every registered field is built from its defaults and gives finite forces
// on a blurred disk (2D) and sphere (3D); its schema lists exactly the keys the registry reads
// (each key, given its default, is accepted; the canonical options hold the same keys); entries
// carry a summary and a key table.
#include "fields/registry.h"
#include "framework/core/errors.h"
#include "framework/core/image_filters.h"

#include <cmath>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <set>

namespace dsnake {
namespace {

template <int D>
Image<D> blurred_ball(int size, double radius) {
  Grid<D> grid;
  grid.size = GridIndex<D>::Constant(size);
  grid.spacing = Point<D>::Ones();
  Image<D> image(grid);
  const Point<D> c = Point<D>::Constant((size - 1) / 2.0 + 0.3);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    image[l] = (grid.to_physical(grid.index(l)) - c).norm() < radius ? 200.0f : 50.0f;
  return gaussian_blur(image, 1.0);
}

template <int D>
void expect_every_field_computes_from_defaults(int size, double radius) {
  const Image<D> image = blurred_ball<D>(size, radius);
  const auto& registry = field_registry<D>();
  const std::vector<std::string> names = registry.names();
  EXPECT_EQ(names, (std::vector<std::string>{"ddgvf", "distance", "gradient", "gvf", "vfc"}));
  for (const std::string& name : names) {
    const auto& entry = registry.entry(name);
    ASSERT_TRUE(entry.make_default) << name;
    EXPECT_FALSE(entry.summary.empty()) << name;
    auto field = entry.make_default();
    ASSERT_NE(field, nullptr) << name;
    EXPECT_EQ(field->type(), name);
    field->compute(image);
    const Grid<D>& g = image.grid();
    double largest = 0;
    for (int64_t l = 0; l < g.num_voxels(); l += 3) {
      const Point<D> x = g.to_physical(g.index(l)) + Point<D>::Constant(0.25);
      Point<D> n = Point<D>::Zero();
      n[0] = 0.6, n[1] = -0.8;
      const Point<D> f = field->force(x, n);
      ASSERT_TRUE(f.allFinite()) << name << " at " << x.transpose();
      largest = std::max(largest, f.norm());
      if (field->has_potential()) {
        ASSERT_TRUE(std::isfinite(field->potential(x))) << name;
      }
    }
    EXPECT_GT(largest, 0) << name << ": a zero field on an image with an edge";
  }
}

TEST(FieldRegistry, EveryFieldComputesFromDefaults2d) { expect_every_field_computes_from_defaults<2>(40, 11.0); }
TEST(FieldRegistry, EveryFieldComputesFromDefaults3d) { expect_every_field_computes_from_defaults<3>(24, 7.0); }

template <int D>
void expect_schema_lists_every_key() {
  const auto& registry = field_registry<D>();
  for (const std::string& name : registry.names()) {
    const auto& entry = registry.entry(name);
    ASSERT_TRUE(entry.schema_properties.is_object()) << name;
    EXPECT_FALSE(entry.schema_properties.empty()) << name;
    EXPECT_EQ(entry.rows.size(), entry.schema_properties.size()) << name;
    std::set<std::string> schema_keys;
    for (const auto& [key, property] : entry.schema_properties.items()) {
      schema_keys.insert(key);
      ASSERT_TRUE(property.contains("default")) << name << "." << key;
      EXPECT_FALSE(property.value("description", "").empty()) << name << "." << key;
      const nlohmann::json j = {{"type", name}, {key, nlohmann::json(property["default"])}};
      JsonReader reader(j, "exp.json", "field");
      try {
        auto field = registry.create(reader);
        EXPECT_EQ(field->type(), name);
      } catch (const InputError& e) {
        ADD_FAILURE() << name << "." << key << " = " << property["default"].dump() << " refused: " << e.what();
      }
    }
    // The options the registry reads (every key, defaults made explicit) are the schema's keys.
    const nlohmann::json only_type = {{"type", name}};
    JsonReader reader(only_type, "exp.json", "field");
    const auto spec = registry.read(reader);
    std::set<std::string> read_keys;
    for (const auto& [key, value] : spec.options.items()) read_keys.insert(key);
    EXPECT_EQ(read_keys, schema_keys) << name;
    // And nothing else is accepted.
    const nlohmann::json unknown = {{"type", name}, {"no_such_key", 1}};
    JsonReader ru(unknown, "exp.json", "field");
    EXPECT_THROW(registry.create(ru), InputError) << name;
  }
}

TEST(FieldRegistry, SchemaListsEveryKey2d) { expect_schema_lists_every_key<2>(); }
TEST(FieldRegistry, SchemaListsEveryKey3d) { expect_schema_lists_every_key<3>(); }

TEST(FieldRegistry, EnumKeysListTheirNames) {
  const auto& gvf = field_registry<2>().entry("gvf").schema_properties;
  EXPECT_EQ(gvf["solver"]["enum"], nlohmann::ordered_json({"multigrid", "explicit"}));
  EXPECT_EQ(gvf["solver"]["default"], "multigrid");
  const auto& ddgvf = field_registry<3>().entry("ddgvf").schema_properties;
  EXPECT_EQ(ddgvf["polarity"]["enum"], nlohmann::ordered_json({"dark_inside", "bright_inside"}));
  const auto& vfc = field_registry<2>().entry("vfc").schema_properties;
  EXPECT_EQ(vfc["kernel"]["enum"], nlohmann::ordered_json({"power", "gaussian"}));
  EXPECT_EQ(vfc["radius"]["exclusiveMinimum"], 0.0);
  const auto& distance = field_registry<2>().entry("distance").schema_properties;
  EXPECT_EQ(distance["threshold"]["exclusiveMinimum"], 0.0);
  EXPECT_EQ(distance["threshold"]["maximum"], 1.0);
}

}  // namespace
}  // namespace dsnake
