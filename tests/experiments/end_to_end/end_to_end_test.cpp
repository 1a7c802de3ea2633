// End-to-end registrations on the built-in phantoms, checked against their ground truth.
#include "experiments/spec/experiment.h"
#include "experiments/output/runner.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("dsnake_e2e_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(d);
  return d;
}

template <int D>
nlohmann::ordered_json run_builtin(const std::string& name, const fs::path& out,
                                   const std::vector<std::string>& overrides = {}) {
  auto ex = make_experiment<D>(builtin_experiment(name, overrides));
  return run_experiment(ex, RunOptions{out.string(), true});
}

// The built-in default is D-Snake on the paper's Fig. 4: the template's vertices land on their
// counterparts (the slice's points at the same arc length from the corner), the corner on the
// corner, and the figure joins each template vertex to where it landed.
TEST(EndToEnd, DefaultRegistersTheLungSliceTemplateVertexByVertex) {
  const fs::path out = fresh_dir("default");
  const auto r = run_builtin<2>("default", out);
  const auto& m = r["metrics"];
  EXPECT_GT(m["dice"].get<double>(), 0.99);
  EXPECT_LT(m["mean_surface_distance"].get<double>(), 0.3);
  EXPECT_LT(m["correspondence_error_mean"].get<double>(), 0.3);  // placed 8.8 mm off on average
  EXPECT_LT(m["correspondence_error_max"].get<double>(), 1.0);
  EXPECT_EQ(m["self_intersections"].get<int>(), 0);
  EXPECT_TRUE(r["success"].get<bool>());
  EXPECT_EQ(r["vertices"]["initial"].get<int>(), 32);
  EXPECT_GT(r["vertices"]["final"].get<int>(), 32);  // the resampling phase refined it
  // The corner (template vertex 0, landmark "corner") on the slice's corner.
  std::ifstream csv(out / "correspondence.csv");
  std::string header, corner;
  std::getline(csv, header);
  std::getline(csv, corner);
  EXPECT_EQ(corner.rfind("0,corner,", 0), 0u) << corner;
  const double corner_error = std::stod(corner.substr(corner.rfind(',') + 1));
  EXPECT_LT(corner_error, 1.5) << corner;  // placed 9.8 mm from it
  EXPECT_TRUE(fs::exists(out / "overlay.png"));
  fs::remove_all(out);
}

TEST(EndToEnd, CircleTemplateRegistersToABlurredSquare2d) {
  const fs::path out = fresh_dir("square");
  const auto r = run_builtin<2>("classical", out);
  const auto& m = r["metrics"];
  EXPECT_LT(m["mean_surface_distance"].get<double>(), 1.0);
  EXPECT_GT(m["dice"].get<double>(), 0.9);
  EXPECT_EQ(m["self_intersections"].get<int>(), 0);
  EXPECT_TRUE(r["success"].get<bool>());
  for (const char* f : {"result.json", "final.txt", "final.vtk", "initial.vtk", "correspondence.csv",
                        "energy_trace.csv", "overlay.png"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  // the curves and report.html are the command line's report step (experiments/output/report_step.h)
  for (const char* f : {"energy.png", "convergence.png", "report.html"}) EXPECT_FALSE(fs::exists(out / f)) << f;
  // result.json is the document returned, and has the contract's keys.
  std::ifstream in(out / "result.json");
  const auto j = nlohmann::json::parse(in);
  for (const char* k : {"metrics", "success", "iterations", "vertices", "timings", "config", "version"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["vertices"]["initial"].get<int>(), 64);
  EXPECT_GT(j["vertices"]["final"].get<int>(), 64);  // the resampling phase refined it
  // final.vtk holds only numbers VTK's legacy reader parses (it refuses "nan"): the free vertices
  // that resampling added have displacement 0 and template_id -1.
  std::ifstream vtk(out / "final.vtk");
  const std::string text((std::istreambuf_iterator<char>(vtk)), {});
  EXPECT_EQ(text.find("nan"), std::string::npos);
  EXPECT_EQ(text.find("inf"), std::string::npos);
  EXPECT_NE(text.find("SCALARS displacement"), std::string::npos);
  fs::remove_all(out);
}

TEST(EndToEnd, SphereTemplateRegistersToABlurredEllipsoid3d) {
  const fs::path out = fresh_dir("ellipsoid");
  const auto r = run_builtin<3>("ellipsoid", out);
  const auto& m = r["metrics"];
  EXPECT_LT(m["mean_surface_distance"].get<double>(), 1.0);
  EXPECT_GT(m["dice"].get<double>(), 0.9);
  EXPECT_EQ(m["self_intersections"].get<int>(), 0);
  for (const char* f : {"result.json", "final.ply", "final.vtk", "slices.png", "correspondence.csv"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  fs::remove_all(out);
}

TEST(EndToEnd, SameNumbersWhateverTheThreadCount) {
  const fs::path a = fresh_dir("threads1"), b = fresh_dir("threads2");
  omp_set_num_threads(1);
  const auto r1 = run_builtin<2>("default", a, {"phases[0].iterations=150"});
  omp_set_num_threads(2);
  const auto r2 = run_builtin<2>("default", b, {"phases[0].iterations=150"});
  EXPECT_EQ(r1["metrics"].dump(), r2["metrics"].dump());
  std::ifstream f1(a / "final.txt"), f2(b / "final.txt");
  const std::string s1((std::istreambuf_iterator<char>(f1)), {}), s2((std::istreambuf_iterator<char>(f2)), {});
  EXPECT_EQ(s1, s2);
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(EndToEnd, SnapshotsAreWrittenEveryNIterations) {
  const fs::path out = fresh_dir("snapshots");
  run_builtin<2>("default", out, {"phases[0].iterations=20", "phases[1].iterations=10", "output.snapshot_every=10",
                                  "output.figures=false"});
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(out / "snapshots")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"iteration_000010.vtk", "iteration_000020.vtk", "iteration_000030.vtk"}));
  EXPECT_FALSE(fs::exists(out / "overlay.png"));
  // The trace has one row per iteration (plus the header).
  std::ifstream trace(out / "energy_trace.csv");
  const auto rows = std::count(std::istreambuf_iterator<char>(trace), {}, '\n');
  EXPECT_EQ(rows, 31);
  fs::remove_all(out);
}

TEST(EndToEnd, DefaultCommandWritesNonNullMetricsAndFigures) {
  const fs::path out = fresh_dir("cli");
  const std::string cmd = std::string(DSNAKE_EXE) + " run --quiet --out " + out.string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(out / "result.json");
  const auto j = nlohmann::json::parse(in);
  for (const auto& [k, v] : j["metrics"].items()) EXPECT_FALSE(v.is_null()) << k;
  EXPECT_TRUE(fs::exists(out / "overlay.png"));
  fs::remove_all(out);
}

}  // namespace
}  // namespace dsnake
