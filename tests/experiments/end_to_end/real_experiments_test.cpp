// The real-scan experiments (experiments/real/, REPRODUCTION.md "Real scans"): every
// case runs the recipe's settings with only its inputs replaced, and the 2D cases (fast: about a
// second each) run here end to end on ITK's example scans: the recipe ends better than it
// starts, the rat lung (slice 1 as its atlas image, recipe_2d_with_atlas.json) reaches Dice 0.96,
// and started on the lung's true contour the recipe stays there. The 3D cases take minutes; they run as experiments (experiments/real/run.sh).
#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <vector>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kReal = fs::path(DSNAKE_SOURCE_DIR) / "experiments" / "real";

json read_json(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

// Every case's "recipe" and "fixed_point" methods (the four real scans and the anatomy
// development set) take a recipe file as it is and override only inputs: what a user changes
// when copying it. "recipe" runs the case's own recipe (the sweep's base); "fixed_point" names a
// reference image, so it runs what dsnake init prints with --reference (recipe_2d_with_atlas.json
// or recipe_3d.json), the sweep's base or its own. The anatomy cases' methods without an atlas
// image ("recipe_noref", "fixed_point_noref") do the same with recipe_3d_without_atlas.json as
// their base, and name no reference image.
TEST(RealExperiments, RecipeMethodsChangeOnlyTheInputs) {
  const std::set<std::string> inputs = {"name", "image", "template", "ground_truth", "output"};
  const std::set<std::string> template_inputs = {"file", "reference_image", "transform"};
  int cases = 0;
  std::vector<fs::path> folders;  // experiments/real/CASE and experiments/real/anatomy/CASE
  for (const fs::path& root : {kReal, kReal / "anatomy"})
    for (const auto& entry : fs::directory_iterator(root))
      if (fs::exists(entry.path() / "sweep.json")) folders.push_back(entry.path());
  for (const fs::path& folder : folders) {
    const fs::path sweep = folder / "sweep.json";
    ++cases;
    const json s = read_json(sweep);
    const std::string recipe = s.at("base").get<std::string>();
    const std::string up = folder.parent_path() == kReal ? "../" : "../../";
    EXPECT_TRUE(recipe == up + "recipe_2d.json" || recipe == up + "recipe_2d_with_atlas.json" ||
                recipe == up + "recipe_3d.json")
        << sweep;
    const bool anatomy = folder.parent_path() != kReal;
    std::vector<std::string> methods = {"recipe", "fixed_point"};
    if (anatomy) methods.insert(methods.end(), {"recipe_noref", "fixed_point_noref"});
    for (const std::string& method : methods) {
      SCOPED_TRACE(sweep.string() + " " + method);
      const json& m = s.at("methods").at(method);
      const bool noref = method.ends_with("_noref");
      if (noref) {
        EXPECT_EQ(m.value("base", ""), up + "recipe_3d_without_atlas.json");
      } else if (method == "fixed_point") {
        const std::string base = m.value("base", recipe);
        EXPECT_TRUE(base == up + "recipe_2d_with_atlas.json" || base == up + "recipe_3d.json") << base;
      } else {
        EXPECT_FALSE(m.contains("base"));
      }
      // An override is an object per section ("template": {"file": ...}) or a key path
      // ("template.file"); either way its section and, for template and output, its key.
      for (const auto& [key, value] : m.at("overrides").items()) {
        const size_t dot = key.find('.');
        const std::string section = key.substr(0, dot);
        EXPECT_TRUE(inputs.count(section)) << key;
        std::vector<std::string> keys;
        if (dot != std::string::npos) keys.push_back(key.substr(dot + 1));
        else if (value.is_object()) {
          for (const auto& [k, v] : value.items()) keys.push_back(k);
        }
        for (const auto& k : keys) {
          if (section == "template") {
            EXPECT_TRUE(template_inputs.count(k)) << key << " " << k;
            if (noref) {
              EXPECT_NE(k, "reference_image") << key;
            }
          } else if (section == "output") {
            EXPECT_EQ(k, "start_metrics") << key;
          }
        }
      }
    }
  }
  EXPECT_GE(cases, 4 + 9);  // the four real scans and the nine anatomy cases
}

class RealExperiments2d : public test_support::TempDirTest {
 protected:
  // Runs the case's sweep into dir_/case and returns each method's result.json.
  std::map<std::string, json> run_case(const std::string& name) {
    const fs::path out = dir_ / name;
    const std::string cmd = std::string(DSNAKE_EXE) + " sweep " + (kReal / name / "sweep.json").string() + " --out " +
                            out.string() + " -j 1 -q 2>" + (dir_ / "err.txt").string();
    EXPECT_EQ(std::system(cmd.c_str()), 0) << slurp(dir_ / "err.txt");
    std::map<std::string, json> results;
    for (const auto& run : fs::directory_iterator(out / "runs")) {
      const std::string id = run.path().filename().string();
      results[id.substr(0, id.find("-g"))] = read_json(run.path() / "result.json");
    }
    return results;
  }
  static double metric(const json& r, const char* key) { return r.at("metrics").at(key).get<double>(); }
  static double start_metric(const json& r, const char* key) { return r.at("start").at("metrics").at(key).get<double>(); }
  static void print(const std::string& what, const json& r) {
    std::printf("  %s: Dice %.4f -> %.4f, msd %.3f -> %.3f mm, HD95 %.2f mm, centroid shift %.2f mm\n", what.c_str(),
                start_metric(r, "dice"), metric(r, "dice"), start_metric(r, "mean_surface_distance"),
                metric(r, "mean_surface_distance"), metric(r, "hausdorff95"), r.at("pose").at("centroid_shift").get<double>());
  }
};

TEST_F(RealExperiments2d, TheRecipeImprovesTheRatLungAndTheCorpusCallosumAndHoldsTheirTrueContours) {
  // The inputs (reference segmentations, templates) from ITK's example data, made in data/real/.
  const std::string make = "/usr/bin/python3 " + (kReal / "make_2d_inputs.py").string() + " " + DSNAKE_EXE + " " +
                           DSNAKE_SOURCE_DIR + " >/dev/null";
  ASSERT_EQ(std::system(make.c_str()), 0);

  auto lung = run_case("lung");
  ASSERT_EQ(lung.size(), 4u);
  const json& r = lung["recipe"];
  print("lung recipe", r);
  // Measured: Dice 0.9222 -> 0.9689, msd 0.92 -> 0.44 mm, HD95 1.55 mm (elastix: 0.965;
  // recipe_2d.json's profile force with the same atlas: 0.9505).
  EXPECT_GE(metric(r, "dice"), 0.96);
  EXPECT_GT(metric(r, "dice"), start_metric(r, "dice"));
  EXPECT_LT(metric(r, "mean_surface_distance"), start_metric(r, "mean_surface_distance"));
  EXPECT_EQ(r["metrics"]["self_intersections"], 0);
  // The paper's lung-slice settings collapse the contour (Dice 0.26): reported, not asserted
  // beyond "the recipe is better".
  EXPECT_GT(metric(r, "dice"), metric(lung["paper"], "dice"));
  EXPECT_GT(metric(r, "dice"), metric(lung["classical"], "dice"));
  const json& f = lung["fixed_point"];
  print("lung fixed point", f);
  EXPECT_NEAR(metric(f, "dice"), start_metric(f, "dice"), 0.01);  // measured: 0.9989 -> 0.9989
  EXPECT_LE(f["pose"]["centroid_shift"].get<double>(), 0.5);      // measured: 0.00 mm

  auto cc = run_case("cc");
  ASSERT_EQ(cc.size(), 5u);
  const json& c = cc["recipe"];
  print("corpus callosum recipe", c);
  // Measured: Dice 0.387 -> 0.895, msd 2.94 -> 0.65 mm.
  EXPECT_GT(metric(c, "dice"), start_metric(c, "dice") + 0.3);
  EXPECT_LT(metric(c, "mean_surface_distance"), 0.5 * start_metric(c, "mean_surface_distance"));
  EXPECT_EQ(c["metrics"]["self_intersections"], 0);
  const json& cf = cc["fixed_point"];
  print("corpus callosum fixed point", cf);
  EXPECT_NEAR(metric(cf, "dice"), start_metric(cf, "dice"), 0.01);  // measured: 0.9905 -> 0.9905
  EXPECT_LE(cf["pose"]["centroid_shift"].get<double>(), 0.5);       // measured: 0.03 mm
  // With the generic step edge instead, the start drifts to the CC's gradient maxima, 0.7 px
  // outside the reference's iso-level (Dice 0.990 -> 0.892, REPRODUCTION.md): reported.
  print("corpus callosum fixed point, no reference", cc["fixed_point_no_reference"]);
}

}  // namespace
}  // namespace dsnake
