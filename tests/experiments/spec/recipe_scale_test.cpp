// The recipes' lengths scaled to a small structure (experiments/spec/recipe_scale.h): the
// equivalent radius of known shapes, the factor, and which keys of the real recipes are lengths
// (scaled, defaults written out) and which are not (left as they are).
#include "experiments/spec/recipe_scale.h"

#include "experiments/phantoms/phantoms.h"
#include "experiments/spec/recipes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace dsnake {
namespace {

using json = nlohmann::ordered_json;

TEST(RecipeScale, TheEquivalentRadiusOfASphereAndADiscIsTheirRadius) {
  Template<3> sphere = make_icosphere(4);  // 2562 vertices: its volume within 0.2% of the ball's
  for (auto& p : sphere.positions) p *= 5.0;
  EXPECT_NEAR(equivalent_radius<3>(sphere), 5.0, 0.01);
  Template<2> disc;
  const int n = 720;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    disc.positions.push_back(Point<2>(3 + 4 * std::cos(a), -1 + 4 * std::sin(a)));
  }
  disc.connectivity = Connectivity::polygon(n);
  EXPECT_NEAR(equivalent_radius<2>(disc), 4.0, 0.001);
  // Orientation does not matter: the same disc clockwise.
  std::reverse(disc.positions.begin(), disc.positions.end());
  EXPECT_NEAR(equivalent_radius<2>(disc), 4.0, 0.001);
}

TEST(RecipeScale, OnlyAStructureSmallerThanTheRecipesOwnIsScaled) {
  EXPECT_DOUBLE_EQ(recipe_length_scale(kRecipeRadiusMm / 2), 0.5);
  EXPECT_DOUBLE_EQ(recipe_length_scale(kRecipeRadiusMm), 1.0);
  EXPECT_DOUBLE_EQ(recipe_length_scale(4 * kRecipeRadiusMm), 1.0);
  EXPECT_DOUBLE_EQ(recipe_length_scale(0.0), 1.0);  // nothing to measure by
  EXPECT_DOUBLE_EQ(recipe_length_scale(3.86), 0.551);  // 0.55143 to 3 significant digits
}

TEST(RecipeScale, TheRecipeWithAnAtlasHasEveryLengthScaledAndNothingElse) {
  const json recipe = json::parse(recipe_json(3, true));
  json j = recipe;
  scale_lengths(j, 3, 0.5);
  EXPECT_DOUBLE_EQ(j["field"]["sigma"].get<double>(), 0.5 * recipe["field"]["sigma"].get<double>());
  EXPECT_DOUBLE_EQ(j["field"]["region"]["margin"].get<double>(), 10.0);
  for (int e : {1, 3}) {  // the coarse and the fine patch force
    SCOPED_TRACE(e);
    for (const char* key : {"sigma", "radius", "spacing"})
      EXPECT_DOUBLE_EQ(j["energies"][e][key].get<double>(), 0.5 * recipe["energies"][e][key].get<double>()) << key;
    EXPECT_DOUBLE_EQ(j["energies"][e]["map_radius"].get<double>(), 3.0);  // its default (6 mm), written out
    EXPECT_FALSE(j["energies"][e].contains("max_step"));                   // default 0: the sampling step, scaled with it
    EXPECT_EQ(j["energies"][e]["weight"], recipe["energies"][e]["weight"]);
  }
  EXPECT_DOUBLE_EQ(j["template"]["init"]["margin"].get<double>(), 5.0);
  EXPECT_EQ(j["template"]["init"]["levels"], json::parse("[2.0, 1.0, 0.5]"));
  for (int k : {0, 1}) {
    EXPECT_DOUBLE_EQ(j["phases"][k]["tolerance"].get<double>(), 0.005);
    EXPECT_EQ(j["phases"][k]["weights"], recipe["phases"][k]["weights"]);
    EXPECT_EQ(j["phases"][k]["iterations"], recipe["phases"][k]["iterations"]);
  }
  // The tension's alpha has a unit that depends on its discretisation: left as it is; so are the
  // ASAP-MLS rings (edges, not mm).
  EXPECT_EQ(j["energies"][0], recipe["energies"][0]);
  EXPECT_EQ(j["energies"][2], recipe["energies"][2]);
  EXPECT_EQ(j["energies"][4], recipe["energies"][4]);
  // k = 1 changes nothing.
  json same = recipe;
  scale_lengths(same, 3, 1.0);
  EXPECT_EQ(same, recipe);
}

TEST(RecipeScale, TheRecipeWithoutAnAtlasHasItsProfileAndPolarityLengthsScaled) {
  const json recipe = json::parse(recipe_json(3, false));
  json j = recipe;
  scale_lengths(j, 3, 0.25);
  for (int e : {2, 4}) {
    SCOPED_TRACE(e);
    for (const char* key : {"sigma", "search", "length", "max_travel"})
      EXPECT_DOUBLE_EQ(j["energies"][e][key].get<double>(), 0.25 * recipe["energies"][e][key].get<double>()) << key;
    EXPECT_DOUBLE_EQ(j["energies"][e]["step"].get<double>(), 0.5);  // a share of the best offset, not a length
    EXPECT_DOUBLE_EQ(j["energies"][e]["min_improvement"].get<double>(), 0.3);
  }
  // The external term: its polarity rule's lengths (defaults 1 and 5 mm) written out scaled; its
  // step tau, whose unit depends on "normalize", left as it is.
  EXPECT_DOUBLE_EQ(j["energies"][1]["polarity_sigma"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(j["energies"][1]["polarity_range"].get<double>(), 1.25);
  EXPECT_EQ(j["energies"][1]["tau"], recipe["energies"][1]["tau"]);
  EXPECT_DOUBLE_EQ(j["phases"][1]["tolerance"].get<double>(), 0.0025);
}

TEST(RecipeScale, In2DTheProfileAndToleranceScaleAndTheTensionAndFieldDiffusionDoNot) {
  const json recipe = json::parse(recipe_json(2, false));
  json j = recipe;
  scale_lengths(j, 2, 0.5);
  EXPECT_DOUBLE_EQ(j["energies"][2]["search"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(j["energies"][2]["length"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(j["energies"][2]["max_travel"].get<double>(), 0.075);  // 0.15 mm at half the size
  EXPECT_DOUBLE_EQ(j["phases"][0]["tolerance"].get<double>(), 0.005);
  EXPECT_FALSE(j["field"].contains("mu"));  // mm^2 per unit of a normalised edge map: invariant
  EXPECT_EQ(j["energies"][0], recipe["energies"][0]);
}

// Voxels coarser than the recipe's: only a patch force finer than a quarter of the largest voxel
// side is coarsened, its sigma to h / 4 and its radius and spacing in proportion; nothing else.
TEST(RecipeScale, OnCoarseVoxelsOnlyThePatchesFinerThanAQuarterVoxelAreCoarsened) {
  const json recipe = json::parse(recipe_json(3, true));
  json j = recipe;
  EXPECT_DOUBLE_EQ(coarsen_patches_to_voxels(j, 3, 2.0), 1.0);  // the fine patch's 0.5 mm is h / 4 already
  EXPECT_EQ(j, recipe);
  EXPECT_DOUBLE_EQ(coarsen_patches_to_voxels(j, 3, 5.0), 2.5);
  for (const char* key : {"sigma", "radius", "spacing"})  // the fine patch: 0.5, 2, 0.5 mm times 2.5
    EXPECT_DOUBLE_EQ(j["energies"][3][key].get<double>(), 2.5 * recipe["energies"][3][key].get<double>()) << key;
  json rest = j, rest_recipe = recipe;
  rest["energies"][3] = rest_recipe["energies"][3] = nullptr;
  EXPECT_EQ(rest, rest_recipe);  // the coarse patch (sigma 2 mm > 5 / 4), the init, the phases: as they were
  // A patch with its defaults (sigma 1, radius 3, spacing 0: the voxel size) on 8 mm voxels:
  // sigma and radius written out doubled, the 0 spacing kept; the recipe without an atlas has none.
  json d = json::parse(R"({"energies": [{"type": "patch", "weight": 1.0}, {"type": "internal", "weight": 1.0}]})");
  EXPECT_DOUBLE_EQ(coarsen_patches_to_voxels(d, 3, 8.0), 2.0);
  EXPECT_EQ(d["energies"][0], json::parse(R"({"type": "patch", "weight": 1.0, "sigma": 2.0, "radius": 6.0})"));
  EXPECT_EQ(d["energies"][1], json::parse(R"({"type": "internal", "weight": 1.0})"));
  json without = json::parse(recipe_json(3, false));
  const json copy = without;
  EXPECT_DOUBLE_EQ(coarsen_patches_to_voxels(without, 3, 6.0), 1.0);
  EXPECT_EQ(without, copy);
}

}  // namespace
}  // namespace dsnake
