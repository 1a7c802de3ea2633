// `dsnake init`: the file it prints is the recipe (experiments/real/recipe_3d.json; in 2D
// recipe_2d_with_atlas.json or recipe_2d_without_atlas.json) with only the
// inputs replaced, valid, and run as printed (with the template started 10% too small) it
// registers a label volume it was not tuned for; a scan outside the recipe's voxel range gets a
// warning; bad input exits 2 with one line and prints nothing.
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

class InitCommandTest : public test_support::CommandTest {
 protected:
  // A label volume: 1 inside an ellipsoid (semi-axes 14, 11, 9 mm), anisotropic voxels; the
  // whole volume scaled by `scale` about the world origin (voxels, origin and ellipsoid).
  fs::path ellipsoid_labels(double scale = 1.0, const Point<3>& semi_axes = Point<3>(14, 11, 9),
                            const std::string& name = "labels.nii.gz") {
    Grid<3> g{GridIndex<3>(44, 36, 26), scale * Point<3>(0.8, 0.8, 1.2), scale * Point<3>(-20, 35, 7)};
    Image<3> im(g, 0.0f);
    const Point<3> c = g.origin + 0.5 * (g.size.cast<double>() - Point<3>::Ones()).cwiseProduct(g.spacing);
    for (int64_t l = 0; l < im.num_voxels(); ++l) {
      const Point<3> d = (g.to_physical(g.index(l)) - c).cwiseQuotient(scale * semi_axes);
      im[l] = d.squaredNorm() <= 1 ? 1.0f : 0.0f;
    }
    const fs::path p = dir_ / name;
    write_image<3>(im, p.string());
    return p;
  }
};

// The recipe file of a dimension with its inputs (name, description, image, template,
// ground_truth) removed: what `dsnake init` must keep as it is.
nlohmann::json settings_of(nlohmann::json j) {
  for (const char* k : {"name", "description", "image", "template", "ground_truth"}) j.erase(k);
  return j;
}

TEST_F(InitCommandTest, PrintsTheRecipeWithOnlyTheInputsReplacedAndItsRunRegistersTheVolume) {
  const fs::path labels = ellipsoid_labels(), tmpl = dir_ / "t.off";
  ASSERT_EQ(dsnake("template --mask " + labels.string() + " --label 1 --vertices 400 --out " + tmpl.string()), 0) << err_;
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template " + tmpl.string() + " --reference " +
                   labels.string() + " --mask " + labels.string()),
            0)
      << err_;
  const nlohmann::json j = nlohmann::json::parse(out_);
  EXPECT_EQ(j["dimension"], 3);
  EXPECT_TRUE(fs::path(j["image"]["file"].get<std::string>()).is_absolute());
  EXPECT_EQ(j["template"]["reference_image"], fs::absolute(labels).string());
  EXPECT_EQ(j["ground_truth"]["mask"], fs::absolute(labels).string());
  std::ifstream recipe(std::string(DSNAKE_SOURCE_DIR) + "/experiments/real/recipe_3d.json");
  ASSERT_TRUE(recipe.good());
  EXPECT_EQ(settings_of(j), settings_of(nlohmann::json::parse(recipe)));
  EXPECT_EQ(err_, "");  // 0.8 x 1.2 mm voxels: within the recipe's range, no warning
  const fs::path exp = dir_ / "exp.json";
  std::ofstream(exp) << out_;
  ASSERT_EQ(dsnake("validate " + exp.string()), 0) << err_;

  // Started 10% small on a label volume nobody tuned it for (its own label as the atlas image:
  // the template's rest surface sits on its boundary there): the recipe's template.init finds
  // the scale (1 / 0.9) from the images alone, and the run ends on the boundary.
  const fs::path run = dir_ / "run";
  ASSERT_EQ(dsnake("run " + exp.string() + " -o " + run.string() +
                   " -j 2 --quiet --set template.transform.scale=0.9 --set output.start_metrics=true"),
            0)
      << err_;
  const nlohmann::json r = nlohmann::json::parse(slurp(run / "result.json"));
  std::printf("  init scale %.4f, NCC %.3f -> %.3f; Dice %.4f, mean distance %.3f mm\n", r["init"]["scale"].get<double>(),
              r["init"]["ncc_before"].get<double>(), r["init"]["ncc_after"].get<double>(),
              r["metrics"]["dice"].get<double>(), r["metrics"]["mean_surface_distance"].get<double>());
  EXPECT_NEAR(r["init"]["scale"].get<double>(), 1 / 0.9, 0.01);
  EXPECT_GT(r["init"]["ncc_after"].get<double>(), r["init"]["ncc_before"].get<double>());
  EXPECT_GT(r["init"]["ncc_after"].get<double>(), 0.999);
  EXPECT_GT(r["metrics"]["dice"].get<double>(), 0.99);
  EXPECT_LT(r["metrics"]["mean_surface_distance"].get<double>(), 0.25);
  EXPECT_EQ(r["metrics"]["self_intersections"], 0);
  EXPECT_TRUE(fs::exists(run / "result_mask.nii.gz"));
  EXPECT_FALSE(fs::exists(run / "image.nii.gz"));  // a file read as it is is not copied
}

// Without --reference (no atlas image) in 3D: the recipe for that case, with no reference image
// and no image init, and one warning line saying that an atlas image is recommended and why.
TEST_F(InitCommandTest, WithoutAnAtlasImageItWritesTheRecipeForThatAndSaysWhyAnAtlasHelps) {
  const fs::path labels = ellipsoid_labels(), tmpl = dir_ / "t.off";
  ASSERT_EQ(dsnake("template --mask " + labels.string() + " --label 1 --vertices 200 --out " + tmpl.string()), 0) << err_;
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template " + tmpl.string()), 0) << err_;
  const nlohmann::json j = nlohmann::json::parse(out_);
  std::ifstream recipe(std::string(DSNAKE_SOURCE_DIR) + "/experiments/real/recipe_3d_without_atlas.json");
  ASSERT_TRUE(recipe.good());
  EXPECT_EQ(settings_of(j), settings_of(nlohmann::json::parse(recipe)));
  EXPECT_FALSE(j["template"].contains("reference_image"));
  EXPECT_FALSE(j["template"].contains("init"));
  EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
  EXPECT_NE(err_.find("warning: no --reference: an atlas image"), std::string::npos) << err_;
  EXPECT_NE(err_.find("contrast changes side"), std::string::npos) << err_;
  const fs::path exp = dir_ / "exp.json";
  std::ofstream(exp) << out_;
  EXPECT_EQ(dsnake("validate " + exp.string()), 0) << err_;
}

// In 2D with --reference: recipe_2d_with_atlas.json with only the inputs replaced, and its run
// registers a mixed-polarity disk (darker than its surroundings on one side, brighter on the
// other: no single edge polarity fits it) moved and scaled in the image, from the template drawn
// on the atlas; the template is checked against the atlas image, on which it lies, not against
// the image. Without --reference: recipe_2d_without_atlas.json (a polish: it does no harm on that
// boundary) and one warning line saying why an atlas helps.
TEST_F(InitCommandTest, In2DWithAnAtlasItWritesTheAtlasRecipeAndItsRunRegistersAMixedPolarityDisk) {
  // The disk (radius r mm, centre c), 0.5 mm pixels, 80 mm across: as an image, at 100 on a
  // background of 30 left of x = c.x and 170 right of it; as a label, 1 inside.
  auto disk = [&](const Point<2>& c, double r, bool label, const std::string& name) {
    Grid<2> g{GridIndex<2>(160, 160), Point<2>(0.5, 0.5), Point<2>(-40, -40)};
    Image<2> im(g, 0.0f);
    for (int64_t l = 0; l < im.num_voxels(); ++l) {
      const Point<2> x = g.to_physical(g.index(l));
      const bool inside = (x - c).norm() <= r;
      im[l] = label ? float(inside) : inside ? 100.0f : x(0) < c(0) ? 30.0f : 170.0f;
    }
    const fs::path p = dir_ / name;
    write_image<2>(im, p.string());
    return p;
  };
  const fs::path contour = dir_ / "disk.txt";
  auto write_circle = [&](const Point<2>& c) {  // 40 vertices on a circle of radius 12 (2 mm apart)
    std::ofstream out(contour);
    for (int i = 0; i < 40; ++i) {
      const double t = 2 * M_PI * i / 40;
      out << c(0) + 12 * std::cos(t) << " " << c(1) + 12 * std::sin(t) << "\n";
    }
  };
  const Point<2> atlas_centre(-6, 4), scan_centre(-2.5, 1);
  const fs::path atlas = disk(atlas_centre, 12, false, "atlas.nii.gz"), scan = disk(scan_centre, 13.2, false, "scan.nii.gz");
  const fs::path truth = disk(scan_centre, 13.2, true, "truth.nii.gz");
  write_circle(atlas_centre);  // on the atlas's disk
  ASSERT_EQ(dsnake("init --image " + scan.string() + " --template " + contour.string() + " --reference " +
                   atlas.string() + " --mask " + truth.string()),
            0)
      << err_;
  EXPECT_EQ(err_, "");
  const nlohmann::json j = nlohmann::json::parse(out_);
  EXPECT_EQ(j["dimension"], 2);
  EXPECT_EQ(j["template"]["reference_image"], fs::absolute(atlas).string());
  std::ifstream recipe(std::string(DSNAKE_SOURCE_DIR) + "/experiments/real/recipe_2d_with_atlas.json");
  ASSERT_TRUE(recipe.good());
  EXPECT_EQ(settings_of(j), settings_of(nlohmann::json::parse(recipe)));
  EXPECT_EQ(j["template"]["init"]["type"], "image");
  const fs::path exp = dir_ / "exp.json", run = dir_ / "run";
  std::ofstream(exp) << out_;
  ASSERT_EQ(dsnake("run " + exp.string() + " -o " + run.string() + " -j 2 --quiet --set output.start_metrics=true"), 0)
      << err_;
  const nlohmann::json r = nlohmann::json::parse(slurp(run / "result.json"));
  std::printf("  init scale %.4f; Dice %.4f -> %.4f, mean distance %.3f mm\n", r["init"]["scale"].get<double>(),
              r["start"]["metrics"]["dice"].get<double>(), r["metrics"]["dice"].get<double>(),
              r["metrics"]["mean_surface_distance"].get<double>());
  EXPECT_NEAR(r["init"]["scale"].get<double>(), 1.1, 0.01);
  EXPECT_GT(r["metrics"]["dice"].get<double>(), 0.98);
  EXPECT_LT(r["metrics"]["mean_surface_distance"].get<double>(), 0.25);

  // A template off the atlas image (200 mm away: more than its extent beyond its border) is
  // refused, naming the atlas: it is checked against the atlas, on which it should lie.
  write_circle(Point<2>(200, 0));
  EXPECT_EQ(dsnake("init --image " + scan.string() + " --template " + contour.string() + " --reference " +
                   atlas.string()),
            2);
  EXPECT_NE(err_.find("the template lies outside the atlas image " + atlas.string()), std::string::npos) << err_;

  // Without --reference: the recipe without an atlas (a polish), the warning naming recipe_2d.json
  // for a one-polarity object, and the polish run holds the placed disk on its mixed boundary.
  write_circle(scan_centre);
  ASSERT_EQ(dsnake("init --image " + scan.string() + " --template " + contour.string() + " --mask " + truth.string()), 0)
      << err_;
  std::ifstream without(std::string(DSNAKE_SOURCE_DIR) + "/experiments/real/recipe_2d_without_atlas.json");
  ASSERT_TRUE(without.good());
  EXPECT_EQ(settings_of(nlohmann::json::parse(out_)), settings_of(nlohmann::json::parse(without)));
  EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
  EXPECT_NE(err_.find("warning: no --reference: an atlas image"), std::string::npos) << err_;
  EXPECT_NE(err_.find("only polishes"), std::string::npos) << err_;
  EXPECT_NE(err_.find("experiments/real/recipe_2d.json follows that one polarity"), std::string::npos) << err_;
  const fs::path polish = dir_ / "polish.json", polish_run = dir_ / "polish";
  std::ofstream(polish) << out_;
  ASSERT_EQ(dsnake("run " + polish.string() + " -o " + polish_run.string() + " -j 2 --quiet --set output.start_metrics=true"),
            0)
      << err_;
  const nlohmann::json p = nlohmann::json::parse(slurp(polish_run / "result.json"));
  std::printf("  without an atlas: Dice %.4f -> %.4f\n", p["start"]["metrics"]["dice"].get<double>(),
              p["metrics"]["dice"].get<double>());
  // The disk of radius 12 on the truth of radius 13.2: at most max_travel (0.15 mm) nearer.
  EXPECT_GE(p["metrics"]["dice"].get<double>(), p["start"]["metrics"]["dice"].get<double>() - 0.01);
  EXPECT_LE(p["metrics"]["dice"].get<double>(), 0.97);
}

// Slices 4 mm thick (beyond the recipe's 3 mm): with an atlas, the fine patch force (sigma 0.5 mm)
// is made as coarse as a quarter of a slice (sigma 1, radius 4, spacing 1 mm) and one note says so;
// the coarse patches, the image init and the phases are the recipe's. Without an atlas (no patch
// force) the recipe is kept and a warning says the voxels are beyond what it was chosen on.
TEST_F(InitCommandTest, OnThickSlicesThePatchesAreMadeAsCoarseAsTheVoxels) {
  Grid<3> g{GridIndex<3>(40, 40, 10), Point<3>(1.0, 1.0, 4.0), Point<3>(-20, -20, -18)};
  Image<3> im(g, 0.0f);
  for (int64_t l = 0; l < im.num_voxels(); ++l)
    im[l] = (g.to_physical(g.index(l))).cwiseQuotient(Point<3>(12, 10, 11)).squaredNorm() <= 1 ? 1.0f : 0.0f;
  const fs::path image = dir_ / "thick.nii.gz", tmpl = dir_ / "t.off";
  write_image<3>(im, image.string());
  ASSERT_EQ(dsnake("template --mask " + image.string() + " --label 1 --vertices 300 --out " + tmpl.string()), 0) << err_;
  ASSERT_EQ(dsnake("init --image " + image.string() + " --template " + tmpl.string() + " --reference " + image.string()), 0)
      << err_;
  const nlohmann::json j = nlohmann::json::parse(out_);
  std::ifstream recipe_file(std::string(DSNAKE_SOURCE_DIR) + "/experiments/real/recipe_3d.json");
  nlohmann::json recipe = nlohmann::json::parse(recipe_file);
  EXPECT_EQ(j["energies"][3], nlohmann::json::parse(R"({"type": "patch", "weight": 1.0, "sigma": 1.0, "radius": 4.0,
                                                        "spacing": 1.0})"));
  nlohmann::json rest = settings_of(j);
  rest["energies"][3] = recipe["energies"][3] = nullptr;
  EXPECT_EQ(rest, settings_of(recipe));
  EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
  EXPECT_NE(err_.find("dsnake: note: " + image.string() + ": voxels of up to 4 mm"), std::string::npos) << err_;
  EXPECT_NE(j["description"].get<std::string>().find("Voxels: voxels of up to 4 mm"), std::string::npos);
  ASSERT_EQ(dsnake("init --image " + image.string() + " --template " + tmpl.string()), 0) << err_;
  std::ifstream without(std::string(DSNAKE_SOURCE_DIR) + "/experiments/real/recipe_3d_without_atlas.json");
  EXPECT_EQ(settings_of(nlohmann::json::parse(out_)), settings_of(nlohmann::json::parse(without)));
  EXPECT_NE(err_.find("dsnake: warning: " + image.string() + ": voxels of up to 4 mm"), std::string::npos) << err_;
}

TEST_F(InitCommandTest, WarnsWhenTheVoxelsAreOutsideTheRecipesRange) {
  Grid<2> g{GridIndex<2>(440, 440), Point<2>(0.05, 0.05), Point<2>(0, 0)};  // 22 mm across
  Image<2> im(g, 0.0f);
  const fs::path image = dir_ / "tiny.nii.gz", contour = dir_ / "c.txt";
  write_image<2>(im, image.string());
  // A 20 mm square (equivalent radius 11.3 mm): the recipe's own size, 0.05 mm voxels.
  std::ofstream(contour) << "0 0\n20 0\n20 20\n0 20\n";
  ASSERT_EQ(dsnake("init --image " + image.string() + " --template " + contour.string()), 0) << err_;
  EXPECT_NE(err_.find("warning: " + image.string() + ": voxels of up to 0.05 mm"), std::string::npos) << err_;
  EXPECT_EQ(nlohmann::json::parse(out_)["dimension"], 2);
  // A 1 mm square on the same voxels: the recipe scaled to it (by 0.56 / 7), the voxels in
  // proportion (0.62 mm at the recipe's scale): a note, no warning.
  std::ofstream(contour) << "0.5 0.5\n1.5 0.5\n1.5 1.5\n0.5 1.5\n";
  ASSERT_EQ(dsnake("init --image " + image.string() + " --template " + contour.string()), 0) << err_;
  EXPECT_EQ(err_.find("voxels of up to"), std::string::npos) << err_;
  EXPECT_NE(err_.find("dsnake: note: the template's equivalent radius is 0.564 mm"), std::string::npos) << err_;
  EXPECT_DOUBLE_EQ(nlohmann::json::parse(out_)["energies"][2]["search"].get<double>(), 2.0 * 0.0806);  // k = 0.564 / 7
}

// A structure smaller than the recipe's (another species' brain): the printed lengths are in
// proportion to its size, so that the same structure at half the size gets the same run, half
// as large: the same Dice, half the surface distance.
TEST_F(InitCommandTest, ASmallStructureGetsTheRecipesLengthsInProportionToItsSize) {
  const Point<3> semi_axes(8, 6.3, 5);  // equivalent radius 6.3 mm, below the recipe's 7
  const fs::path full = ellipsoid_labels(1.0, semi_axes, "full.nii.gz"), half = ellipsoid_labels(0.5, semi_axes, "half.nii.gz");
  const fs::path t_full = dir_ / "full.off", t_half = dir_ / "half.off";
  ASSERT_EQ(dsnake("template --mask " + full.string() + " --label 1 --vertices 300 --out " + t_full.string()), 0) << err_;
  Template<3> t = read_mesh_template(t_full.string());
  for (auto& p : t.positions) p *= 0.5;
  write_mesh(t.positions, t.connectivity, t_half.string());

  nlohmann::json exp[2];
  double dice[2], distance[2];
  const fs::path labels[2] = {full, half}, templates[2] = {t_full, t_half};
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    ASSERT_EQ(dsnake("init --image " + labels[i].string() + " --template " + templates[i].string() + " --reference " +
                     labels[i].string() + " --mask " + labels[i].string()),
              0)
        << err_;
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
    EXPECT_NE(err_.find("dsnake: note: the template's equivalent radius is"), std::string::npos) << err_;
    exp[i] = nlohmann::json::parse(out_);
    const fs::path file = dir_ / ("exp" + std::to_string(i) + ".json"), run = dir_ / ("run" + std::to_string(i));
    std::ofstream(file) << out_;
    ASSERT_EQ(dsnake("run " + file.string() + " -o " + run.string() + " -j 2 --quiet --set template.transform.scale=0.9"), 0)
        << err_;
    const nlohmann::json r = nlohmann::json::parse(slurp(run / "result.json"));
    dice[i] = r["metrics"]["dice"].get<double>();
    distance[i] = r["metrics"]["mean_surface_distance"].get<double>();
  }
  // Full size: scaled by its radius over 7 mm (below 1); half size: by half that.
  const double k_full = exp[0]["energies"][1]["sigma"].get<double>() / 2.0;
  EXPECT_LT(k_full, 0.95);
  EXPECT_GT(k_full, 0.8);
  // (k to 3 significant digits: half of k_full within 0.2%)
  for (const char* key : {"sigma", "radius", "spacing", "map_radius"})
    EXPECT_NEAR(exp[1]["energies"][3][key].get<double>() / exp[0]["energies"][3][key].get<double>(), 0.5, 1e-3) << key;
  EXPECT_NEAR(exp[1]["template"]["init"]["levels"][0].get<double>() / (2 * k_full), 1.0, 2e-3);
  EXPECT_NEAR(exp[1]["phases"][1]["tolerance"].get<double>() / (0.005 * k_full), 1.0, 2e-3);
  // The printed lengths read: k has 3 significant digits, so the coarse patch's sigma (2 mm k)
  // has at most 4 decimals.
  EXPECT_DOUBLE_EQ(std::round(k_full * 1000) / 1000, k_full);
  std::printf("  k %.3f; Dice %.4f / %.4f, mean distance %.3f / %.3f mm\n", k_full, dice[0], dice[1], distance[0],
              distance[1]);
  EXPECT_GT(dice[0], 0.95);
  EXPECT_NEAR(dice[1], dice[0], 0.002);
  EXPECT_NEAR(distance[1], 0.5 * distance[0], 0.05 * distance[0]);
}

TEST_F(InitCommandTest, BadInputExitsTwoWithOneLineAndPrintsNothing) {
  const fs::path labels = ellipsoid_labels(), tmpl = dir_ / "t.off", flat = dir_ / "flat.nii.gz";
  ASSERT_EQ(dsnake("template --mask " + labels.string() + " --label 1 --vertices 200 --out " + tmpl.string()), 0) << err_;
  write_image<2>(Image<2>(Grid<2>{GridIndex<2>(8, 8), Point<2>(1, 1), Point<2>(0, 0)}, 0.0f), flat.string());
  const std::string good = "init --image " + labels.string() + " --template " + tmpl.string();
  for (const std::string& args : {"init --image " + labels.string() + " --template " + (dir_ / "missing.off").string(),
                                  good + " --reference " + (dir_ / "missing_atlas.nii.gz").string(),
                                  good + " --reference " + flat.string(),
                                  "init --image " + (dir_ / "missing.nii").string() + " --template x.off",
                                  "init --image " + labels.string() + " --template " + labels.string()}) {
    SCOPED_TRACE(args);
    EXPECT_EQ(dsnake(args), 2);
    EXPECT_EQ(out_, "");
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
    EXPECT_NE(err_.find("dsnake: error: "), std::string::npos) << err_;
  }
  // An empty path is named by its option (the readers would refuse a file without a name).
  ASSERT_EQ(dsnake("init --image '' --template " + tmpl.string()), 2);
  EXPECT_NE(err_.find("dsnake: error: --image: must be a non-empty file name"), std::string::npos) << err_;
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template ''"), 2);
  EXPECT_NE(err_.find("dsnake: error: --template: must be a non-empty file name"), std::string::npos) << err_;
  // A reference image of the wrong dimension is named with the option it came from.
  ASSERT_EQ(dsnake(good + " --reference " + flat.string()), 2);
  EXPECT_NE(err_.find(flat.string() + ": --reference: expected a 3D image"), std::string::npos) << err_;
  // A template smaller than a voxel (a tetrahedron 0.5 mm across, inside the image, on 0.8 x 1.2 mm voxels) is
  // refused here, as `dsnake run` would refuse the file, not printed into a file that cannot run.
  const fs::path tiny = dir_ / "tiny.off";
  std::ofstream(tiny) << "OFF\n4 4 0\n0 45 20\n0.3 45 20\n0 45.3 20\n0 45 20.3\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template " + tiny.string()), 2);
  EXPECT_EQ(out_, "");
  EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
  EXPECT_NE(err_.find(tiny.string() + ": --template: the template spans 0.52 mm, less than a voxel (0.8 mm)"),
            std::string::npos) << err_;
  // So is a template placed far from the image (its vertices 500 mm off), in `dsnake run`'s words.
  const fs::path far = dir_ / "far.off";
  std::ofstream(far) << "OFF\n4 4 0\n500 0 0\n510 0 0\n500 10 0\n500 0 10\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template " + far.string()), 2);
  EXPECT_EQ(out_, "");
  EXPECT_NE(err_.find(far.string() + ": --template: the template lies outside the image: vertex 0 is more than the "
                                     "image's extent beyond its border along axis 0"),
            std::string::npos)
      << err_;
  // With an atlas image the printed recipe registers the whole atlas onto the whole scan first,
  // so the template must lie near the atlas, not the scan: the far template is printed against an
  // atlas placed where it lies, and refused against this one, naming the atlas.
  Image<3> moved_atlas = read_image<3>(labels.string());
  Grid<3> moved_grid = moved_atlas.grid();
  moved_grid.origin += Point<3>(480, -20, -20);
  const fs::path far_atlas = dir_ / "far_atlas.nii.gz";
  write_image<3>(Image<3>(moved_grid, std::vector<float>(moved_atlas.data().begin(), moved_atlas.data().end())),
                 far_atlas.string());
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template " + far.string() + " --reference " + far_atlas.string()), 0)
      << err_;
  EXPECT_NE(out_.find("\"whole_image\": \"rigid\""), std::string::npos) << out_;
  ASSERT_EQ(dsnake("init --image " + labels.string() + " --template " + far.string() + " --reference " + labels.string()), 2);
  EXPECT_EQ(out_, "");
  EXPECT_NE(err_.find(far.string() + ": --template: the template lies outside the atlas image " + labels.string() +
                     " (--reference), on which it should lie: vertex 0 is more than the image's extent beyond its border"),
            std::string::npos)
      << err_;
  // An atlas image that `dsnake run` would refuse (a NaN voxel) is read whole and named now.
  Image<3> atlas = read_image<3>(labels.string());
  atlas.at(GridIndex<3>(5, 6, 7)) = std::numeric_limits<float>::quiet_NaN();
  const fs::path nan_atlas = dir_ / "nan_atlas.nii.gz";
  write_image<3>(atlas, nan_atlas.string());
  ASSERT_EQ(dsnake(good + " --reference " + nan_atlas.string()), 2);
  EXPECT_EQ(out_, "");
  EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
  EXPECT_NE(err_.find(nan_atlas.string() + ": voxel (5, 6, 7): value is NaN"), std::string::npos) << err_;
}

}  // namespace
}  // namespace dsnake
