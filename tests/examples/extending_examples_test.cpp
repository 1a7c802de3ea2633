// docs/extending.md's worked examples (docs/examples/: the umbrella energy, the intensity field
// and the free-vertex smoothing remesher), registered as a program of its own registers them
// (framework/core/program_plugins.h) and run through an experiment file: the registries list
// them beside the built-in plug-ins, the schema carries their keys, and a registration built
// only from them ends where their forces balance on a disk phantom, by hand-computed radius.
#include "docs/examples/free_smoothing_remesher.h"
#include "docs/examples/intensity_field.h"
#include "docs/examples/umbrella_energy.h"
#include "energies/registry.h"
#include "experiments/output/runner.h"
#include "experiments/spec/experiment.h"
#include "experiments/spec/schema.h"
#include "fields/registry.h"
#include "framework/core/program_plugins.h"
#include "remesh/registry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <unistd.h>

namespace dsnake {
namespace {

// As a program would, before anything reads an experiment.
const bool kRegistered = [] {
  register_plugin<Energy<2>, UmbrellaEnergy<2>>();
  register_plugin<ExternalField<2>, IntensityField<2>>();
  register_plugin<Remesher<2>, FreeSmoothingRemesher<2>>();
  return true;
}();

// A dark disk (radius 20 mm, edge blurred by sigma 1.5 mm) and a 24-vertex circle of radius 19 mm
// inside it. The intensity field pushes the polygon out towards the bright background with
// tau exp(-d^2 / (2 sigma^2)) at distance d from the edge; the umbrella step pulls each vertex of
// a regular n-gon of radius r in by lambda r (1 - cos(2 pi / n)). The fit ends where the two
// balance, outside the edge. Then one iteration of arc-length resampling inserts free vertices
// and the free smoothing stage relaxes them.
const char* kExperiment = R"({
  "name": "extending_examples",
  "dimension": 2,
  "seed": 1,
  "image": {"phantom": "disk", "size": [64, 64], "radius": 20, "blur": 1.5},
  "template": {"phantom": "circle", "radius": 19, "vertices": 24, "center": [31.5, 31.5]},
  "field": {"type": "intensity", "toward": "bright"},
  "energies": [
    {"type": "umbrella", "weight": 1.0, "lambda": 0.5},
    {"type": "external", "weight": 1.0, "tau": 0.5}],
  "phases": [
    {"name": "fit", "iterations": 2000, "tolerance": 1e-6},
    {"name": "refine", "iterations": 1,
     "remesh": [{"type": "resample", "min_edge": 1.0, "max_edge": 3.0}, {"type": "free_smoothing", "lambda": 0.5}]}]
})";

// The radius where the umbrella's pull equals the field's push (bisection on [R, R + 5 sigma]).
double balance_radius(double R, double sigma, double lambda, double tau, int n) {
  const double pull = lambda * (1.0 - std::cos(2.0 * M_PI / n));
  double lo = R, hi = R + 5 * sigma;
  for (int i = 0; i < 100; ++i) {
    const double r = 0.5 * (lo + hi), d = r - R;
    (tau * std::exp(-d * d / (2 * sigma * sigma)) > pull * r ? lo : hi) = r;
  }
  return 0.5 * (lo + hi);
}

TEST(ExtendingExamples, RegisteredBesideTheBuiltInPlugins) {
  ASSERT_TRUE(kRegistered);
  EXPECT_TRUE(energy_registry<2>().contains("umbrella"));
  EXPECT_TRUE(energy_registry<2>().contains("asap_mls"));
  EXPECT_TRUE(field_registry<2>().contains("intensity"));
  EXPECT_TRUE(remesher_registry<2>().contains("free_smoothing"));
  EXPECT_FALSE(energy_registry<3>().contains("umbrella"));  // registered for 2D only
  // The schema of experiment files comes from the registries: the example's keys with its range.
  const std::string schema = experiment_schema().dump();
  EXPECT_NE(schema.find("explicit umbrella smoothing"), std::string::npos);
  EXPECT_NE(schema.find("towards bright or dark voxels"), std::string::npos);
  // The registries are built: a later registration would be lost, so it is refused.
  EXPECT_THROW((register_plugin<Energy<2>, UmbrellaEnergy<2>>()), std::logic_error);
}

TEST(ExtendingExamples, TheExamplesAloneFitADiskWhereTheirForcesBalance) {
  ASSERT_TRUE(kRegistered);
  ExperimentFile file;
  file.document = nlohmann::json::parse(kExperiment);
  file.dimension = 2;
  const auto out = std::filesystem::temp_directory_path() / ("dsnake_examples_" + std::to_string(::getpid()));
  std::filesystem::remove_all(out);
  auto ex = make_experiment<2>(file);
  const auto r = run_experiment(ex, RunOptions{out.string(), true});
  EXPECT_EQ(r["phases"][0]["status"], "converged");
  // The template vertices' distances from the centre, as the fit left them (one more iteration
  // moves them by less than 0.01 mm).
  std::ifstream csv(out / "correspondence.csv");
  std::string line;
  std::getline(csv, line);
  std::vector<double> radii;
  while (std::getline(csv, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    radii.push_back(std::hypot(std::stod(cells[4]) - 31.5, std::stod(cells[5]) - 31.5));
  }
  ASSERT_EQ(radii.size(), 24u);
  const double expected = balance_radius(20.0, 1.5, 0.5, 0.5, 24);  // 21.3 mm
  for (double radius : radii) EXPECT_NEAR(radius, expected, 0.15);
  // The refine phase's stages ran: resampling inserted free vertices between the template's.
  const auto& stages = r["phases"][1]["remesh"];
  ASSERT_EQ(stages.size(), 2u);
  EXPECT_EQ(stages[1]["stage"], "free_smoothing");
  EXPECT_GT(stages[0]["vertices_after"].get<int>(), 24);
  EXPECT_EQ(r["vertices"]["final"], stages[0]["vertices_after"]);
  EXPECT_EQ(r["metrics"]["self_intersections"].get<int>(), 0);
  std::filesystem::remove_all(out);
}

}  // namespace
}  // namespace dsnake
