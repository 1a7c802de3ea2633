// Every registered energy, found by walking the registry (no hand-kept list): made from its
// defaults, its options validate, its schema lists exactly the keys it reads, and bound to a
// wobbly polygon / sphere it proposes finite positions for the vertices it governs; and the worked
// example of docs/extending.md (docs/examples/umbrella_energy.*) registers, reads, checks and
// proposes as hand-computed.
#include "docs/examples/umbrella_energy.h"
#include "energies/registry.h"
#include "fields/gradient.h"
#include "framework/core/errors.h"
#include "framework/core/image.h"
#include "tests/energy_fixtures.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace dsnake {
namespace {

using test_support::wobbly_polygon;
using test_support::wobbly_sphere;

template <int D>
Image<D> blurred_ball_image() {
  GridIndex<D> size = GridIndex<D>::Constant(D == 2 ? 48 : 28);
  Image<D> image(Grid<D>{size, Point<D>::Ones(), Point<D>::Constant(-0.5 * (size[0] - 1))}, 170.0f);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    if (image.grid().to_physical(image.grid().index(l)).norm() < 9.0) image[l] = 85.0f;
  return image;
}

template <int D>
void every_energy_conforms(const Template<D>& t) {
  const Image<D> image = blurred_ball_image<D>();
  GradientField<D> field;
  field.compute(image);
  const auto& registry = energy_registry<D>();
  ASSERT_GE(registry.names().size(), 6u);
  for (const auto& name : registry.names()) {
    SCOPED_TRACE(std::to_string(D) + "D " + name);
    const auto& entry = registry.entry(name);
    EXPECT_FALSE(entry.summary.empty());
    // every schema key is accepted, at its default, by the reader
    nlohmann::json all = {{"type", name}};
    for (auto it = entry.schema_properties.begin(); it != entry.schema_properties.end(); ++it)
      all[it.key()] = it.value()["default"];
    JsonReader r(all, "test.json", "energies[0]");
    EXPECT_NO_THROW(registry.read(r));
    // and an unknown key is refused, naming it
    nlohmann::json unknown = {{"type", name}, {"no_such_key", 1}};
    JsonReader u(unknown, "test.json", "energies[0]");
    try {
      registry.read(u);
      ADD_FAILURE() << "unknown key accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "energies[0].no_such_key");
    }
    auto energy = entry.make_default();
    EXPECT_EQ(energy->type(), name);
    Snake<D> snake = Snake<D>::from_template(t, test_support::perturbed<D>(t.positions, 0.3, 5));
    energy->check_template(t);
    EnergyContext<D> context{&t, &image, &field, nullptr};
    context.reference_image = &image;  // an atlas image, for the terms that need one (patch)
    energy->bind(context, snake);
    PointList<D> out(snake.num_vertices(), Point<D>::Constant(NAN));
    energy->propose(snake, out);
    const auto mask = energy->governed_mask();
    if (energy->governs() == Governs::kMarkedVertices) {
      EXPECT_EQ(int(mask.size()), snake.num_vertices());
    }
    for (int v = 0; v < snake.num_vertices(); ++v) {
      const Governs g = energy->governs();
      if (g == Governs::kAllVertices || (g == Governs::kDeformationVertices && snake.is_deformation_vertex(v)) ||
          (g == Governs::kMarkedVertices && mask[v])) {
        EXPECT_TRUE(out[v].allFinite()) << "vertex " << v;
      }
    }
  }
}

TEST(EnergyConformance, EveryRegisteredEnergyFromItsDefaults) {
  every_energy_conforms<2>(wobbly_polygon(24, 8.0));
  every_energy_conforms<3>(wobbly_sphere(1, 8.0));
}

// The example energy of docs/extending.md: one registration line, then reading, range checks,
// the proposal and the value against hand-computed numbers on the unit square.
TEST(ExtendingExample, UmbrellaEnergyRegistersReadsAndProposes) {
  Registry<Energy<2>> registry;
  registry.add<UmbrellaEnergy<2>>();
  ASSERT_TRUE(registry.contains("umbrella"));
  const auto schema = registry.entry("umbrella").schema_properties;
  EXPECT_EQ(schema["lambda"]["exclusiveMinimum"], 0.0);
  EXPECT_EQ(schema["lambda"]["maximum"], 1.0);
  EXPECT_EQ(schema["lambda"]["default"], 0.5);

  nlohmann::json bad = {{"type", "umbrella"}, {"lambda", 0}};
  JsonReader rb(bad, "test.json", "energies[0]");
  try {
    registry.read(rb);
    ADD_FAILURE() << "lambda 0 accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "energies[0].lambda");
    EXPECT_EQ(e.message(), "must be in (0, 1]");
  }

  nlohmann::json spec = {{"type", "umbrella"}, {"lambda", 0.25}};
  JsonReader r(spec, "test.json", "energies[0]");
  auto energy = registry.read(r).build();
  Template<2> square;
  square.positions = {Point<2>(0, 0), Point<2>(1, 0), Point<2>(1, 1), Point<2>(0, 1)};
  square.connectivity = Connectivity::polygon(4);
  PointList<2> q = square.positions;
  q[0] = Point<2>(-1, -1);  // one corner pulled out
  Snake<2> snake = Snake<2>::from_template(square, q);
  energy->bind({&square}, snake);
  PointList<2> out(4);
  energy->propose(snake, out);
  // vertex 0: neighbours (1, 0) and (0, 1), mean (0.5, 0.5); (-1, -1) + 0.25 (1.5, 1.5)
  EXPECT_NEAR(out[0].x(), -0.625, 1e-15);
  EXPECT_NEAR(out[0].y(), -0.625, 1e-15);
  // vertex 2: neighbours (1, 0) and (0, 1): mean (0.5, 0.5); (1, 1) + 0.25 (-0.5, -0.5)
  EXPECT_NEAR(out[2].x(), 0.875, 1e-15);
  // value: 1/2 (|(2, 1)|^2 + 1 + 1 + |(1, 2)|^2) = 1/2 (5 + 1 + 1 + 5) = 6
  EXPECT_NEAR(energy->value(snake), 6.0, 1e-12);
}

}  // namespace
}  // namespace dsnake
