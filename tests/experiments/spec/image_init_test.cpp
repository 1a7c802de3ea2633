// "template.init": {"type": "image"} in experiments: a template whose file positions lie on an
// object of the reference image (the ITK brain slice in 2D, Colin27 cut about the basal ganglia
// in 3D) is placed, with no transform, on a scan that is the reference moved by a known map with
// another contrast; the image init brings every vertex back onto the moved object within
// 0.5 mm (similarity and affine; with a rough placement given as template.transform too), and
// result.json's "init" reports the map and the fit. Bad values of the new keys are one-line
// errors naming the file and the JSON path (exit 2 on the command line).
#include "experiments/spec/experiment.h"
#include "experiments/output/runner.h"
#include "experiments/spec/template_init.h"
#include "framework/core/errors.h"
#include "framework/core/image_filters.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "tests/energies/edge_images.h"
#include "tests/experiments/temp_dir_test.h"

#include <Eigen/SVD>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <cstdlib>
#include <fstream>
#include <sys/wait.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace test_support;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

// S(y) = a R(T^-1 y) + b on R's grid: the reference moved by T, another contrast.
template <int D>
Image<D> moved(const Image<D>& reference, const AffineMap<D>& T, double a, double b) {
  const AffineMap<D> inv = T.inverse();
  const Grid<D>& g = reference.grid();
  Image<D> out(g);
  for (int64_t l = 0; l < out.num_voxels(); ++l)
    out[l] = float(a * reference.sample(g.to_frame(inv.apply(g.to_world(g.to_physical(g.index(l)))))) + b);
  return out;
}

template <int D>
AffineMap<D> about(const Point<D>& c, const Eigen::Matrix<double, D, D>& M, const Point<D>& t) {
  AffineMap<D> m;
  m.matrix = M;
  m.translation = c - M * c + t;
  return m;
}

class ImageInitTest : public TempDirTest {
 protected:
  // The 2D case: the reference slice, the scan (the slice moved by T, 0.8 I + 30) and a circle
  // of radius 15 mm about the ventricles as the template.
  json write_2d(const AffineMap<2>& T) {
    const Image<2> reference = read_image<2>(std::string(DSNAKE_SCANS_DIR) + "/itk/BrainProtonDensitySliceBorder20.mhd");
    write_image<2>(reference, (dir_ / "reference.mha").string());
    write_image<2>(moved<2>(reference, T, 0.8, 30.0), (dir_ / "scan.mha").string());
    tmpl2_ = round_template<2>(15.0, centre2(), 40);
    write_contour(tmpl2_.positions, (dir_ / "template.txt").string());
    return init_experiment("image_init", 2, "template.txt", {{"type", "image"}});
  }
  static Point<2> centre2() { return Point<2>(110, 125); }

  // An experiment that only places the template (one iteration of a tension alone) on scan.mha,
  // with reference.mha as its atlas image and `init` as its template.init.
  static json init_experiment(const std::string& name, int dimension, const std::string& tmpl, const json& init) {
    return {{"name", name}, {"dimension", dimension},
            {"image", {{"file", "scan.mha"}}},
            {"template", {{"file", tmpl}, {"reference_image", "reference.mha"}, {"init", init}}},
            {"field", {{"type", "gradient"}}},
            {"energies", {{{"type", "internal"}, {"weight", 1.0}}}},
            {"phases", {{{"iterations", 1}}}},
            {"output", {{"figures", false}, {"result_mask", false}}}};
  }

  fs::path write(const json& doc) {
    std::ofstream(dir_ / "experiment.json") << doc.dump(2);
    return dir_ / "experiment.json";
  }
  template <int D>
  Experiment<D> experiment(const json& doc) {
    return make_experiment<D>(load_experiment_file(write(doc).string()));
  }
  std::pair<std::string, std::string> error_of(const json& doc) {
    try {
      experiment<2>(doc);
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), (dir_ / "experiment.json").string());
      return {e.where(), e.message()};
    }
    ADD_FAILURE() << "accepted: " << doc.dump();
    return {};
  }

  // The largest distance of the initial (after init) positions from T p, world mm.
  template <int D>
  static double worst(const Experiment<D>& ex, const Template<D>& t, const AffineMap<D>& T) {
    double d = 0;
    for (size_t i = 0; i < t.positions.size(); ++i)
      d = std::max(d, (ex.image.grid().to_world(ex.initial[i]) - T.apply(t.positions[i])).norm());
    return d;
  }

  Template<2> tmpl2_;
};

// A similarity truth (6 deg, scale 1.05, (4, -3) mm): 4.8 mm off before, back within 0.5 mm.
TEST_F(ImageInitTest, TheTemplateIsBroughtBackOntoTheMovedSlice2d) {
  const AffineMap<2> T = about<2>(centre2(), 1.05 * Eigen::Rotation2Dd(6 * kDeg).toRotationMatrix(), Point<2>(4, -3));
  json doc = write_2d(T);
  const Experiment<2> ex = experiment<2>(doc);
  ASSERT_TRUE(ex.init);
  const double after = worst<2>(ex, tmpl2_, T);
  double before = 0;
  for (const auto& p : tmpl2_.positions) before = std::max(before, (p - T.apply(p)).norm());
  std::printf("[ measured ] 2D similarity: %.2f mm off before the init, %.3f mm after\n", before, after);
  EXPECT_GT(before, 4.0);
  EXPECT_LT(after, 0.5);
  const auto j = init_report_json<2>(*ex.init);
  EXPECT_EQ(j["type"], "image");
  EXPECT_EQ(j["transform"], "similarity");
  EXPECT_NEAR(j["scale"].get<double>(), 1.05, 0.005);
  EXPECT_NEAR(j["rotation_deg"].get<double>(), 6.0, 0.5);
  EXPECT_GT(j["ncc_after"].get<double>(), j["ncc_before"].get<double>());
  EXPECT_EQ(j["levels"].size(), 3u);
  EXPECT_GT(j["iterations"].get<int>(), 0);
  EXPECT_FALSE(j.contains("warning"));
  // the map reported is the one applied to the placed template: A p + t
  const Eigen::Matrix2d A{{j["matrix"][0][0].get<double>(), j["matrix"][0][1].get<double>()},
                          {j["matrix"][1][0].get<double>(), j["matrix"][1][1].get<double>()}};
  const Point<2> t(j["translation"][0].get<double>(), j["translation"][1].get<double>());
  for (size_t i = 0; i < tmpl2_.positions.size(); ++i)
    EXPECT_LT((A * tmpl2_.positions[i] + t - ex.image.grid().to_world(ex.initial[i])).norm(), 1e-6);

  // affine truth (shear 0.05): the affine model recovers it; a rough placement given first
  Eigen::Matrix2d shear{{1.04, 0.05}, {0.0, 0.97}};
  const AffineMap<2> Ta = about<2>(centre2(), Eigen::Rotation2Dd(-4 * kDeg).toRotationMatrix() * shear, Point<2>(-3, 2));
  doc = write_2d(Ta);
  doc["template"]["init"]["transform"] = "affine";
  doc["template"]["transform"] = {{"translation", {-2, 1}}};
  const Experiment<2> ea = experiment<2>(doc);
  std::printf("[ measured ] 2D affine: %.3f mm after\n", worst<2>(ea, tmpl2_, Ta));
  EXPECT_LT(worst<2>(ea, tmpl2_, Ta), 0.5);
  const auto ja = init_report_json<2>(*ea.init);
  EXPECT_EQ(ja["transform"], "affine");
  EXPECT_TRUE(ja.contains("matrix"));
  // the scale |det|^(1/2) and the principal scales (singular values, largest first) of the truth's
  const Eigen::Vector2d principal = Eigen::JacobiSVD<Eigen::Matrix2d>(shear).singularValues();
  EXPECT_NEAR(ja["scale"].get<double>(), std::sqrt(shear.determinant()), 0.01);
  ASSERT_EQ(ja["principal_scales"].size(), 2u);
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(ja["principal_scales"][i].get<double>(), principal(i), 0.01);
  EXPECT_FALSE(ja.contains("rotation"));
}

// 3D: Colin27 cut about the left basal ganglia, an icosphere of 12 mm about the putamen, the
// scan moved by a rigid map (5 deg about (1, -1, 2), (3, 2, -2.5) mm), 1.3 I + 10.
TEST_F(ImageInitTest, TheTemplateIsBroughtBackOntoTheMovedVolume3d) {
  const std::string path = std::string(DSNAKE_SCANS_DIR) + "/mricron/ch2.nii.gz";
  ASSERT_TRUE(fs::exists(path)) << "run scripts/fetch_scans.sh";
  const Image<3> whole = read_image<3>(path);
  const Point<3> c(22, -2, 2);  // LPS mm
  const Point<3> ci = whole.grid().to_continuous_index(whole.grid().to_frame(c));
  Grid<3> g = whole.grid();
  GridIndex<3> lo;
  for (int a = 0; a < 3; ++a) lo[a] = int(ci[a]) - 40, g.size[a] = 81;
  g.origin = whole.grid().to_world(whole.grid().to_physical(lo));
  Image<3> reference(g);
  for (int64_t l = 0; l < reference.num_voxels(); ++l) reference[l] = whole.at(GridIndex<3>(g.index(l) + lo));
  const AffineMap<3> T = about<3>(c, Eigen::AngleAxisd(5 * kDeg, Point<3>(1, -1, 2).normalized()).toRotationMatrix(),
                                  Point<3>(3, 2, -2.5));
  write_image<3>(reference, (dir_ / "reference.mha").string());
  write_image<3>(moved<3>(reference, T, 1.3, 10.0), (dir_ / "scan.mha").string());
  const Template<3> t = round_template<3>(12.0, c);
  write_mesh(t.positions, t.connectivity, (dir_ / "template.off").string());
  const json doc = init_experiment("image_init3", 3, "template.off", {{"type", "image"}, {"transform", "rigid"}});
  const Experiment<3> ex = experiment<3>(doc);
  ASSERT_TRUE(ex.init);
  std::printf("[ measured ] 3D rigid: %.3f mm after\n", worst<3>(ex, t, T));
  EXPECT_LT(worst<3>(ex, t, T), 0.5);
  const auto j = init_report_json<3>(*ex.init);
  EXPECT_NEAR(j["scale"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j["rotation_deg"].get<double>(), 5.0, 0.5);
  EXPECT_TRUE(j.contains("rotation_axis"));
}

// A scan in another world frame: the whole Colin27 (block-averaged to 2 mm), its voxels placed
// by a rigid map of 30 degrees and 58 mm (the grid's origin and direction moved, the voxels
// kept: exact), with another contrast, and cut to 60% of its height (another field of view). The
// region's registration alone cannot reach the template's object from the placement; with
// whole_image the whole reference is registered first (from the foreground centroids) and the
// template lands within 0.5 mm of T p; with T the identity it stays there.
TEST_F(ImageInitTest, AScanInAnotherWorldFrameIsReachedThroughTheWholeImage3d) {
  const std::string path = std::string(DSNAKE_SCANS_DIR) + "/mricron/ch2.nii.gz";
  ASSERT_TRUE(fs::exists(path)) << "run scripts/fetch_scans.sh";
  const Image<3> reference = block_average<3>(read_image<3>(path), GridIndex<3>(2, 2, 2));
  write_image<3>(reference, (dir_ / "reference.mha").string());
  const Point<3> c(22, -2, 2);  // LPS mm, the left putamen
  const Template<3> t = round_template<3>(12.0, c);
  write_mesh(t.positions, t.connectivity, (dir_ / "template.off").string());
  auto run = [&](const AffineMap<3>& T, const std::string& whole) {
    const Grid<3>& g = reference.grid();
    Grid<3> h = g;
    const int64_t lo = g.size[2] / 5;
    h.size[2] = g.size[2] * 3 / 5;
    h.origin = T.apply(g.to_world(g.to_physical(GridIndex<3>(0, 0, lo))));
    h.direction = T.matrix * g.direction;
    Image<3> scan(h);
    for (int64_t l = 0; l < scan.num_voxels(); ++l) {
      const GridIndex<3> i = h.index(l);
      scan[l] = 0.7f * reference.at(GridIndex<3>(i[0], i[1], i[2] + lo)) + 40.0f;
    }
    write_image<3>(scan, (dir_ / "scan.mha").string());
    const json doc = init_experiment("whole_image", 3, "template.off",
                                     {{"type", "image"}, {"transform", "rigid"}, {"whole_image", whole}});
    const Experiment<3> ex = experiment<3>(doc);
    EXPECT_TRUE(ex.init);
    return std::make_pair(worst<3>(ex, t, T), init_report_json<3>(*ex.init));
  };
  const AffineMap<3> T = about<3>(c, Eigen::AngleAxisd(30 * kDeg, Point<3>(0.3, 0.5, 0.8).normalized()).toRotationMatrix(),
                                  Point<3>(40, -30, 30));
  const auto [region_only, jr] = run(T, "none");
  const auto [whole, jw] = run(T, "rigid");
  std::printf("[ measured ] 30 deg, 58 mm: region only %.1f mm off, whole image first %.3f mm\n", region_only, whole);
  EXPECT_GT(region_only, 10.0);
  EXPECT_FALSE(jr.contains("whole_image"));
  EXPECT_LT(whole, 0.5);
  ASSERT_TRUE(jw.contains("whole_image")) << jw.dump();
  EXPECT_TRUE(jw["whole_image"]["kept"].get<bool>());
  EXPECT_GT(jw["whole_image"]["ncc_after"].get<double>(), jw["whole_image"]["ncc_before"].get<double>());
  EXPECT_EQ(jw["whole_image"]["levels"].size(), 2u);
  const auto [identity, ji] = run(AffineMap<3>{}, "similarity");
  std::printf("[ measured ] the same frame: whole image first %.3f mm\n", identity);
  EXPECT_LT(identity, 0.5);
}

// The same in 2D: the ITK brain slice's pixels placed 20 degrees and 39 mm away (its grid moved),
// another contrast; the template (a circle about the ventricles) is reached only through the
// whole image.
TEST_F(ImageInitTest, AScanInAnotherWorldFrameIsReachedThroughTheWholeImage2d) {
  json doc = write_2d(AffineMap<2>{});
  const Image<2> reference = read_image<2>((dir_ / "reference.mha").string());
  const AffineMap<2> T = about<2>(Point<2>::Zero(), Eigen::Rotation2Dd(20 * kDeg).toRotationMatrix(), Point<2>(30, -25));
  Grid<2> g = reference.grid();
  g.origin = T.apply(g.origin);
  g.direction = T.matrix * g.direction;
  Image<2> scan(g);
  for (int64_t l = 0; l < scan.num_voxels(); ++l) scan[l] = 0.8f * reference[l] + 30.0f;
  write_image<2>(scan, (dir_ / "scan.mha").string());
  doc["template"]["init"]["transform"] = "rigid";
  const double region_only = worst<2>(experiment<2>(doc), tmpl2_, T);
  doc["template"]["init"]["whole_image"] = "rigid";
  const Experiment<2> ex = experiment<2>(doc);
  const double whole = worst<2>(ex, tmpl2_, T);
  std::printf("[ measured ] 2D, 20 deg, 39 mm: region only %.1f mm off, whole image first %.3f mm\n", region_only, whole);
  EXPECT_GT(region_only, 10.0);
  EXPECT_LT(whole, 0.5);
  EXPECT_TRUE(init_report_json<2>(*ex.init)["whole_image"]["kept"].get<bool>());
}

// Every new key's bad value: the JSON path and one line (exit 2) on the command line.
TEST_F(ImageInitTest, BadImageInitInputsNameTheirJsonPath) {
  const json doc = write_2d(AffineMap<2>{});
  auto with_init = [&](const json& init, bool reference = true) {
    json d = doc;
    d["template"]["init"] = init;
    if (!reference) d["template"].erase("reference_image");
    return d;
  };
  const std::vector<std::pair<json, std::string>> cases = {
      {with_init({{"type", "image"}}, false), "template.init.type"},
      {with_init({{"type", "moments"}, {"threshold", {0, 127}}, {"transform", "affine"}}), "template.init.transform"},
      {with_init({{"type", "image"}, {"transform", "shear"}}), "template.init.transform"},
      {with_init({{"type", "image"}, {"margin", -1}}), "template.init.margin"},
      {with_init({{"type", "image"}, {"margin", "wide"}}), "template.init.margin"},
      {with_init({{"type", "image"}, {"levels", json::array()}}), "template.init.levels"},
      {with_init({{"type", "image"}, {"levels", {4, -1}}}), "template.init.levels"},
      {with_init({{"type", "image"}, {"levels", 4}}), "template.init.levels"},
      {with_init({{"type", "image"}, {"iterations", 0}}), "template.init.iterations"},
      {with_init({{"type", "image"}, {"iterations", 2.5}}), "template.init.iterations"},
      {with_init({{"type", "image"}, {"max_scale", 0.5}}), "template.init.max_scale"},
      {with_init({{"type", "image"}, {"max_scale", -1}}), "template.init.max_scale"},
      {with_init({{"type", "image"}, {"threshold", {0, 1}}}), "template.init.threshold"},
      {with_init({{"type", "image"}, {"points", {{"a", {1, 2}}}}}), "template.init.points"},
      {with_init({{"type", "image"}, {"whole_image", "shear"}}), "template.init.whole_image"},
      {with_init({{"type", "image"}, {"whole_image", true}}), "template.init.whole_image"},
      {with_init({{"type", "moments"}, {"threshold", {0, 127}}, {"whole_image", "rigid"}}), "template.init.whole_image"},
      {with_init({{"type", "image"}, {"whole_image", "rigid"}, {"whole_image_levels", json::array()}}), "template.init.whole_image_levels"},
      {with_init({{"type", "image"}, {"whole_image", "rigid"}, {"whole_image_levels", {8, -4}}}), "template.init.whole_image_levels"}};
  for (const auto& [d, where] : cases) {
    EXPECT_EQ(error_of(d).first, where) << d["template"].dump();
    const fs::path file = write(d);
    const std::string cmd = std::string(DSNAKE_EXE) + " validate " + file.string() + " >/dev/null 2>" + (dir_ / "err.txt").string();
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 2) << where;
    const std::string err = slurp(dir_ / "err.txt");
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_NE(err.find(file.string()), std::string::npos) << err;
    EXPECT_NE(err.find(where), std::string::npos) << err;
  }
}

// A template placed beside the scan (150 mm off, its region outside the image): the init keeps
// the placement with a warning in result.json's "init" (and on stderr), no crash.
TEST_F(ImageInitTest, ATemplateOutsideTheScanKeepsItsPlacementWithAWarning) {
  json doc = write_2d(AffineMap<2>{});
  doc["template"]["transform"] = {{"translation", {150, 0}}};
  const Experiment<2> ex = experiment<2>(doc);
  ASSERT_TRUE(ex.init);
  const auto j = init_report_json<2>(*ex.init);
  EXPECT_NE(j["warning"].get<std::string>().find("outside"), std::string::npos) << j.dump();
  EXPECT_EQ(ex.init->map.matrix, Eigen::Matrix2d::Identity());
  EXPECT_LT(ex.init->map.translation.norm(), 1e-9);
}

}  // namespace
}  // namespace dsnake
