// The paper's figure experiments (Levi & Gotsman, D-Snake: Figs. 2, 4, 6 and 9), run through the
// dsnake command from the files in experiments/paper/, the lung at half size. Each test asserts
// the direction of the paper's claim as we measured it (REPRODUCTION.md (Figures 2, 4, 6, 8, 9)): D-Snake
// keeps its feature points, its corner and its template correspondence where the classical or
// DDGVF snake from the same start does not. Fig. 8 (bar -> C) is
// tests/energies/asap_mls_figures_test.cpp (Fig8BarBecomesTheC): the runner starts a snake from
// its template, so it cannot express a bar snake with a C template.
#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

// What a run wrote: result.json, the per-template-vertex errors of correspondence.csv (by
// landmark name where the vertex has one) and, in 2D, the final contour of final.txt.
struct PaperRun {
  nlohmann::json result;
  std::vector<double> errors;                    // one per template vertex with a target
  std::map<std::string, double> landmark_error;  // landmark name -> error
  std::vector<std::array<double, 2>> contour;    // 2D only

  double metric(const std::string& key) const { return result.at("metrics").at(key).get<double>(); }
  double landmark_mean() const {
    double sum = 0;
    for (const auto& [name, e] : landmark_error) sum += e;
    return landmark_error.empty() ? 0.0 : sum / double(landmark_error.size());
  }
  double landmark_max() const {
    double m = 0;
    for (const auto& [name, e] : landmark_error) m = std::max(m, e);
    return m;
  }
};

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream s(line);
  for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

class FiguresReproductionTest : public test_support::TempDirTest {
 protected:

  // Runs experiments/paper/<name>.json with the --set overrides on one thread and reads its output.
  PaperRun run(const std::string& name, const std::vector<std::string>& overrides = {}) {
    const fs::path file = fs::path(DSNAKE_SOURCE_DIR) / "experiments" / "paper" / (name + ".json");
    const fs::path out = dir_ / name;
    std::string cmd = std::string(DSNAKE_EXE) + " run " + file.string() + " --out " + out.string() + " -q -j 1";
    for (const auto& o : overrides) cmd += " --set '" + o + "'";
    cmd += " >" + (dir_ / "log.txt").string() + " 2>&1";
    const int status = std::system(cmd.c_str());
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << cmd;
    PaperRun r;
    std::ifstream result(out / "result.json");
    r.result = nlohmann::json::parse(result);
    std::ifstream csv(out / "correspondence.csv");
    std::string line;
    std::getline(csv, line);
    const auto header = split_csv_line(line);
    const auto column = [&](const std::string& key) {
      return int(std::find(header.begin(), header.end(), key) - header.begin());
    };
    const int landmark = column("landmark"), error = column("error");
    EXPECT_LT(error, int(header.size()));
    while (std::getline(csv, line)) {
      const auto cells = split_csv_line(line);
      if (error >= int(cells.size()) || cells[error].empty()) continue;
      const double e = std::stod(cells[error]);
      r.errors.push_back(e);
      if (!cells[landmark].empty()) r.landmark_error[cells[landmark]] = e;
    }
    std::ifstream contour(out / "final.txt");
    for (double x, y; contour >> x >> y;) r.contour.push_back({x, y});
    return r;
  }

};

// Distance from p to the closed polygon c.
double distance_to_polygon(const std::array<double, 2>& p, const std::vector<std::array<double, 2>>& c) {
  double best = INFINITY;
  for (size_t i = 0; i < c.size(); ++i) {
    const auto& a = c[i];
    const auto& b = c[(i + 1) % c.size()];
    const double dx = b[0] - a[0], dy = b[1] - a[1], l2 = dx * dx + dy * dy;
    const double u = l2 > 0 ? std::clamp(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2, 0.0, 1.0) : 0.0;
    best = std::min(best, std::hypot(a[0] + u * dx - p[0], a[1] + u * dy - p[1]));
  }
  return best;
}

// Fig. 2: from the same start, both snakes reach the puzzle's edges, but only D-Snake keeps its
// 8 feature points at their counterparts (measured: landmark error mean 0.90 / max 1.47 px for
// D-Snake, 8.90 / 14.0 px for the classical snake).
TEST_F(FiguresReproductionTest, Fig2PuzzleDSnakeKeepsTheFeaturePoints) {
  const PaperRun classical = run("puzzle_classical"), dsnake = run("puzzle_dsnake");
  ASSERT_EQ(classical.landmark_error.size(), 8u);
  ASSERT_EQ(dsnake.landmark_error.size(), 8u);
  EXPECT_LE(classical.metric("mean_surface_distance"), 1.5);  // the classical snake does find the edges
  EXPECT_LE(dsnake.metric("mean_surface_distance"), 1.0);
  EXPECT_LE(dsnake.landmark_max(), 2.0);
  EXPECT_GT(classical.landmark_max(), 5.0);
  EXPECT_GT(classical.landmark_mean(), 4 * dsnake.landmark_mean());
  EXPECT_TRUE(dsnake.result.at("success").get<bool>());
  EXPECT_FALSE(classical.result.at("success").get<bool>());
}

// Fig. 4: the classical snake rounds the lobe's sharp corner off; D-Snake's corner vertex stays at
// the corner (measured: corner vertex error 1.64 px vs 11.4 px; the true corner lies 1.64 px from
// D-Snake's contour and 7.6 px from the classical one).
TEST_F(FiguresReproductionTest, Fig4LungSliceDSnakeKeepsTheCorner) {
  const PaperRun classical = run("lung_slice_classical"), dsnake = run("lung_slice_dsnake");
  ASSERT_EQ(classical.landmark_error.count("corner"), 1u);
  ASSERT_EQ(dsnake.landmark_error.count("corner"), 1u);
  EXPECT_LE(dsnake.landmark_error.at("corner"), 2.0);
  EXPECT_GT(classical.landmark_error.at("corner"), 5.0);
  // The true corner is the corner vertex's target; the phantom puts it first in correspondence.csv.
  std::ifstream csv(dir_ / "lung_slice_dsnake" / "correspondence.csv");
  std::string line;
  std::getline(csv, line);
  const auto header = split_csv_line(line);
  std::getline(csv, line);
  const auto cells = split_csv_line(line);
  const auto at = [&](const std::string& key) {
    return std::stod(cells[std::find(header.begin(), header.end(), key) - header.begin()]);
  };
  const std::array<double, 2> corner = {at("target_x"), at("target_y")};
  ASSERT_EQ(dsnake.contour.size(), 32u);
  ASSERT_EQ(classical.contour.size(), 32u);
  EXPECT_LE(distance_to_polygon(corner, dsnake.contour), 2.0);
  EXPECT_GT(distance_to_polygon(corner, classical.contour), 4.0);  // the contour itself misses the corner
}

// Fig. 6: from the same 20-vertex start, D-Snake fits the T and keeps its template vertices at
// their counterparts better than the DDGVF snake started from the refined template, which does
// not capture the shape. The paper's <= 1 voxel does NOT reproduce: the field's equilibrium at
// the T's corners lies about 1.3 voxels inside along each axis (measured: D-Snake template-vertex
// error mean 2.61 / max 3.63, Dice 0.890; DDGVF 6.87 / 13.2, Dice 0.555, 46 self-intersections).
TEST_F(FiguresReproductionTest, Fig6TetrisDSnakeBeatsDdgvf) {
  const PaperRun dsnake = run("tetris_dsnake"), ddgvf = run("tetris_ddgvf");
  ASSERT_EQ(dsnake.errors.size(), 20u);
  ASSERT_EQ(ddgvf.errors.size(), 20u);
  EXPECT_EQ(dsnake.result.at("vertices").at("initial").get<int>(), 20);
  EXPECT_GT(dsnake.result.at("vertices").at("final").get<int>(), 200);  // the refinement phase ran
  EXPECT_GT(ddgvf.result.at("vertices").at("final").get<int>(), 200);   // DDGVF started refined
  EXPECT_LE(dsnake.metric("mean_surface_distance"), 1.0);
  EXPECT_EQ(dsnake.metric("self_intersections"), 0);
  EXPECT_GT(dsnake.metric("dice"), ddgvf.metric("dice") + 0.2);
  EXPECT_LT(dsnake.metric("correspondence_error_mean"), 0.5 * ddgvf.metric("correspondence_error_mean"));
  EXPECT_LT(dsnake.metric("correspondence_error_max"), 4.0);  // measured 3.63: a regression guard, not the paper's 1
  EXPECT_FALSE(ddgvf.result.at("success").get<bool>());
}

// Fig. 9 at half size (116 x 150 x 40, lobe semi-axes 40 x 60 x 16, thinner bronchi, fewer
// iterations, coarser refinement): D-Snake grows from 310 vertices by refinement and fits the
// lobe despite the bronchi; its template vertices land nearer their targets than those of the
// DDGVF snake started from the refined template (measured: 310 -> 2524 vertices, MSD 0.30, Dice
// 0.982, correspondence mean 2.00; DDGVF MSD 0.29, correspondence mean 4.17).
TEST_F(FiguresReproductionTest, Fig9LungDSnakeRefinesAndKeepsCorrespondence) {
  const std::vector<std::string> half = {
      "image.size=[116,150,40]", "image.semi_axes=[40,60,16]", "image.bronchus_radius=1.5",
      "template.semi_axes=[40,60,16]", "template.center=[57.5,74.5,19.5]"};
  auto dsnake_set = half;
  // the tension in mm^2 scaled with the squared size (0.55 / 4), so that it acts on the half-size lobe as the
  // paper's 0.55 on the full one (a curvature flow's relative speed is alpha / R^2)
  for (const char* s : {"phases[0].iterations=150", "phases[1].iterations=100", "phases[1].remesh[0].max_edge=4",
                        "phases[1].remesh[0].start_max_edge=8", "energies[0].alpha=0.1375"})
    dsnake_set.push_back(s);
  auto ddgvf_set = half;
  for (const char* s : {"phases[1].iterations=250", "phases[0].remesh[0].max_edge=4"}) ddgvf_set.push_back(s);
  const PaperRun dsnake = run("lung_dsnake", dsnake_set), ddgvf = run("lung_ddgvf", ddgvf_set);
  EXPECT_EQ(dsnake.result.at("vertices").at("initial").get<int>(), 310);
  EXPECT_GT(dsnake.result.at("vertices").at("final").get<int>(), 5 * 310);
  EXPECT_LE(dsnake.metric("mean_surface_distance"), 1.0);
  EXPECT_LE(dsnake.metric("hausdorff95"), 2.0);
  EXPECT_GE(dsnake.metric("dice"), 0.9);
  EXPECT_EQ(dsnake.metric("self_intersections"), 0);
  EXPECT_LT(dsnake.metric("correspondence_error_mean"), 2.1);
  EXPECT_GT(ddgvf.metric("correspondence_error_mean"), 1.5 * dsnake.metric("correspondence_error_mean"));
  ASSERT_TRUE(dsnake.result.contains("mesh_quality"));
  EXPECT_TRUE(dsnake.result.at("mesh_quality").at("closed").get<bool>());
  EXPECT_EQ(dsnake.result.at("mesh_quality").at("euler_characteristic").get<int>(), 2);
}

}  // namespace
}  // namespace dsnake
