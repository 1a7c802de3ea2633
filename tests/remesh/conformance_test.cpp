// Every remesher the registry can build (remesher_registry<D>().names(), D = 2 and 3), made
// from its defaults, keeps the remesher contract (framework/core/remesher.h) on a small test shape:
// every deformation vertex keeps its template id and its position, none is lost or added, and
// the result is a closed polygon / closed manifold mesh. And every key of an entry's schema is
// a key that the registry's create() accepts (alone and all together, at its default).
#include "remesh/registry.h"

#include "framework/core/errors.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace dsnake {
namespace {

template <int D>
std::vector<Snake<D>> shapes() {
  if constexpr (D == 2) {
    return {test::uneven_ellipse(40), test::uneven_ellipse(200, 20, 10, 7)};
  } else {
    return {test::with_free_vertices(test::icosphere(2, 10.0), 2),
            test::with_free_vertices(test::torus(24, 12, 6.0, 2.0), 3)};
  }
}

template <int D>
void expect_contract(const Snake<D>& before, const Snake<D>& after) {
  EXPECT_EQ(after.num_deformation_vertices(), before.num_deformation_vertices());
  for (int v = 0; v < before.num_vertices(); ++v) {
    if (!before.is_deformation_vertex(v)) continue;
    const int t = before.template_id(v);
    const int w = after.vertex_of_template_id(t);
    ASSERT_GE(w, 0) << "template id " << t << " lost";
    EXPECT_EQ(after.template_id(w), t);
    EXPECT_EQ(after.positions()[w], before.positions()[v]) << "template id " << t << " moved";
  }
  EXPECT_EQ(after.connectivity().num_vertices(), after.num_vertices());
  if constexpr (D == 2) {
    EXPECT_TRUE(after.connectivity().is_polygon());
    EXPECT_GE(after.num_vertices(), 3);
  } else {
    EXPECT_EQ(after.connectivity().closed_manifold_problem(), "");
    EXPECT_EQ(after.connectivity().euler_characteristic(), before.connectivity().euler_characteristic());
  }
}

template <int D>
void check_every_default_keeps_the_contract() {
  const auto& registry = remesher_registry<D>();
  ASSERT_FALSE(registry.names().empty());
  for (const std::string& name : registry.names()) {
    SCOPED_TRACE(name);
    const auto& entry = registry.entry(name);
    EXPECT_FALSE(entry.summary.empty());
    ASSERT_TRUE(entry.make_default);
    auto remesher = entry.make_default();
    ASSERT_NE(remesher, nullptr);
    EXPECT_EQ(remesher->type(), name);
    for (const Snake<D>& shape : shapes<D>()) {
      Snake<D> s = shape;
      for (int pass = 0; pass < 2; ++pass) {
        const int n = s.num_vertices();
        const RemeshReport report = remesher->apply(s, {});
        EXPECT_EQ(report.stage, name);
        EXPECT_EQ(report.vertices_before, n);
        EXPECT_EQ(report.vertices_after, s.num_vertices());
        expect_contract(shape, s);
      }
    }
  }
}

TEST(RemesherConformance, EveryDefault2DStageKeepsTheContract) { check_every_default_keeps_the_contract<2>(); }
TEST(RemesherConformance, EveryDefault3DStageKeepsTheContract) { check_every_default_keeps_the_contract<3>(); }

template <int D>
void create(const nlohmann::json& j) {
  JsonReader reader(j, "exp.json", "phases[0].remesh[0]");
  const auto remesher = remesher_registry<D>().create(reader);
  EXPECT_EQ(remesher->type(), j.at("type").get<std::string>());
}

template <int D>
void check_every_schema_key_is_accepted() {
  const auto& registry = remesher_registry<D>();
  for (const std::string& name : registry.names()) {
    SCOPED_TRACE(name);
    const auto& properties = registry.entry(name).schema_properties;
    EXPECT_FALSE(properties.empty());
    nlohmann::json all = {{"type", name}};
    for (const auto& [key, property] : properties.items()) {
      SCOPED_TRACE(key);
      ASSERT_TRUE(property.contains("default"));
      const nlohmann::json one = {{"type", name}, {key, property["default"]}};
      EXPECT_NO_THROW(create<D>(one));
      all[key] = property["default"];
    }
    EXPECT_NO_THROW(create<D>(all));
    // Not vacuous: a key outside the schema is refused.
    EXPECT_THROW(create<D>({{"type", name}, {"no_such_key", 1}}), InputError);
  }
}

TEST(RemesherConformance, EverySchemaKeyIsAccepted2D) { check_every_schema_key_is_accepted<2>(); }
TEST(RemesherConformance, EverySchemaKeyIsAccepted3D) { check_every_schema_key_is_accepted<3>(); }

// The other dimension's stages are refused, not listed.
TEST(RemesherConformance, TheOtherDimensionsStagesAreRefusedNotListed) {
  for (const auto& name : remesher_registry<3>().names()) {
    EXPECT_FALSE(remesher_registry<2>().contains(name)) << name;
    EXPECT_THROW(create<2>({{"type", name}}), InputError) << name;
  }
  for (const auto& name : remesher_registry<2>().names()) {
    EXPECT_FALSE(remesher_registry<3>().contains(name)) << name;
    EXPECT_THROW(create<3>({{"type", name}}), InputError) << name;
  }
}

}  // namespace
}  // namespace dsnake
