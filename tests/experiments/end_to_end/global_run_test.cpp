// "solver": "global" end to end: the Ceres solve of an experiment file registers the
// 2D puzzle, reports Ceres' summary and the energy with the file's potential, gives the same
// numbers for any OpenMP thread count, and rejects energies without a least-squares form.
#include "experiments/spec/experiment.h"
#include "experiments/output/runner.h"
#include "framework/core/errors.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("dsnake_global_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(d);
  return d;
}

const std::string kPuzzle = std::string(DSNAKE_SOURCE_DIR) + "/experiments/ablation/global/puzzle_2d.json";

nlohmann::ordered_json run_file(const std::string& path, const fs::path& out, const std::vector<std::string>& overrides) {
  auto ex = make_experiment<2>(load_experiment_file(path, overrides));
  return run_experiment(ex, RunOptions{out.string(), true});
}

TEST(GlobalRun, RegistersThePuzzleAndReportsCeresSummary) {
  const fs::path out = fresh_dir("puzzle");
  const auto r = run_file(kPuzzle, out, {"solver=global"});
  const auto& m = r["metrics"];
  EXPECT_TRUE(r["success"].get<bool>()) << m.dump();
  EXPECT_LT(m["mean_surface_distance"].get<double>(), 1.0);
  EXPECT_LT(m["correspondence_error_max"].get<double>(), 2.0);
  const auto& g = r["global"];
  EXPECT_EQ(g["linear_solver"], "sparse_normal_cholesky");
  ASSERT_EQ(g["solves"].size(), 1u);
  const auto& s = g["solves"][0][0];
  EXPECT_GT(s["iterations"].get<int>(), 0);
  EXPECT_GT(s["residual_evaluations"].get<int>(), 0);
  EXPECT_LT(s["final_cost"].get<double>(), s["initial_cost"].get<double>());
  // The reported energy is the sum of squares Ceres minimised (up to the similarity blocks being
  // at their optimum and the 1e-12 offset inside the potential's square root).
  const double total = r["energy"]["total"].get<double>();
  EXPECT_NEAR(s["final_cost"].get<double>(), total, 1e-3 * total);
  EXPECT_EQ(r["potential"]["type"], "integrated");
  // One trace entry per Ceres iteration reported to the callback (Ceres also counts its last step).
  EXPECT_NEAR(r["iterations"].get<int>(), g["iterations"].get<int>(), 1);
  for (const char* f : {"result.json", "final.txt", "energy_trace.csv", "overlay.png"}) EXPECT_TRUE(fs::exists(out / f)) << f;
  fs::remove_all(out);
}

// One energy for every solver: a snake run values its external term with a potential whether or
// not the file has a "global" object (the default one is the global solve's default), so its
// total is finite, the same with and without that object, and the potential does not move the
// snake.
TEST(GlobalRun, EverySnakeRunValuesItsExternalTermWithThePotential) {
  const fs::path a = fresh_dir("snake_potential"), b = fresh_dir("snake_plain");
  const std::vector<std::string> few{"phases[0].iterations=20"};
  const auto with = run_file(kPuzzle, a, few);
  nlohmann::json doc;
  {
    std::ifstream in(kPuzzle);
    doc = nlohmann::json::parse(in);
  }
  ASSERT_EQ(doc["global"]["potential"], "integrated");
  doc.erase("global");
  const fs::path file = fresh_dir("no_global.json");
  std::ofstream(file) << doc.dump();
  const auto plain = run_file(file.string(), b, few);
  for (const auto* r : {&with, &plain}) {
    for (const auto& [name, value] : (*r)["energy"]["terms"].items()) EXPECT_TRUE(value.is_number()) << name;
    for (const auto& [name, value] : (*r)["energy"]["start"]["terms"].items()) EXPECT_TRUE(value.is_number()) << name;
  }
  EXPECT_EQ(plain["potential"]["type"], "integrated");  // GVF has no potential of its own: the default surrogate
  EXPECT_EQ(with["energy"].dump(), plain["energy"].dump());
  EXPECT_EQ(with["metrics"].dump(), plain["metrics"].dump());  // the potential does not change the snake
  std::ifstream trace(b / "energy_trace.csv");
  const std::string text((std::istreambuf_iterator<char>(trace)), {});
  EXPECT_EQ(text.find("nan"), std::string::npos);
  fs::remove_all(a);
  fs::remove_all(b);
  fs::remove(file);
}

// The snake and the global solve report totals of the same energy: a snake started where the
// global solve ended reports, at its start, the total the global solve reported at its end. The
// field (and its potential) is computed on the whole image in both, so that it does not depend on
// where each run started (field.region "template" crops around the start).
TEST(GlobalRun, ASnakeStartedAtTheGlobalOptimumReportsTheGlobalTotal) {
  const fs::path a = fresh_dir("global_optimum"), b = fresh_dir("snake_from_optimum");
  auto global = make_experiment<2>(load_experiment_file(kPuzzle, {"solver=global", "field.region.extent=whole"}));
  const RunOutcome<2> solved = run_experiment_outcome(global, RunOptions{a.string(), true});
  auto snake = make_experiment<2>(load_experiment_file(kPuzzle, {"phases[0].iterations=5", "field.region.extent=whole"}));
  ASSERT_EQ(snake.solver, SolverKind::kSnake);
  ASSERT_EQ(solved.snake.num_vertices(), int(snake.initial.size()));  // no remeshing: the same vertices
  snake.initial = solved.snake.positions();
  const auto started = run_experiment(snake, RunOptions{b.string(), true});
  const double global_total = solved.result["energy"]["total"].get<double>();
  const double snake_start = started["energy"]["start"]["total"].get<double>();
  EXPECT_GT(global_total, 0.0);
  EXPECT_NEAR(snake_start, global_total, 1e-9 * (1.0 + std::abs(global_total)));
  for (const auto& [name, value] : solved.result["energy"]["terms"].items())
    EXPECT_NEAR(started["energy"]["start"]["terms"][name].get<double>(), value.get<double>(), 1e-9 * (1.0 + std::abs(value.get<double>())))
        << name;
  // and what it reports is what it minimises: five snake steps from there do not lower the total
  // below the global optimum by more than the solver's tolerance
  EXPECT_GT(started["energy"]["total"].get<double>(), global_total * (1.0 - 1e-3));
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(GlobalRun, SameNumbersWhateverTheThreadCount) {
  const fs::path a = fresh_dir("threads1"), b = fresh_dir("threads2");
  const std::vector<std::string> o{"solver=global", "global.max_iterations=40"};
  omp_set_num_threads(1);
  const auto r1 = run_file(kPuzzle, a, o);
  omp_set_num_threads(2);
  const auto r2 = run_file(kPuzzle, b, o);
  EXPECT_EQ(r1["metrics"].dump(), r2["metrics"].dump());
  std::ifstream f1(a / "final.txt"), f2(b / "final.txt");
  const std::string s1((std::istreambuf_iterator<char>(f1)), {}), s2((std::istreambuf_iterator<char>(f2)), {});
  EXPECT_EQ(s1, s2);
  fs::remove_all(a);
  fs::remove_all(b);
}

// A phase with remeshers solves, remeshes and re-solves from the remeshed state remesh_rounds
// times: the built-in default's second phase resamples the contour by arc length.
TEST(GlobalRun, PhasesWithRemeshingSolveRemeshAndResolve) {
  const fs::path out = fresh_dir("remesh");
  auto ex = make_experiment<2>(builtin_experiment(
      "default", {"solver=global", "global.max_iterations=15", "global.remesh_rounds=2"}));
  const auto r = run_experiment(ex, RunOptions{out.string(), true});
  const auto& solves = r["global"]["solves"];
  ASSERT_EQ(solves.size(), 2u);
  EXPECT_EQ(solves[0].size(), 1u);  // no remeshers: one solve
  EXPECT_EQ(solves[1].size(), 3u);  // solve, (remesh, solve) x 2
  EXPECT_GT(r["vertices"]["final"].get<int>(), r["vertices"]["initial"].get<int>());
  EXPECT_EQ(r["phases"][1]["remesh"][0]["stage"], "resample");
  fs::remove_all(out);
}

TEST(GlobalRun, BadGlobalConfigurationsNameTheJsonPath) {
  const auto where = [](const std::vector<std::string>& overrides) {
    try {
      make_experiment<2>(load_experiment_file(kPuzzle, overrides));
    } catch (const InputError& e) {
      return e.where();
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(where({"solver=global", "energies[2]={\"type\": \"balloon\", \"weight\": 0.5}"}), "energies[2].type");
  EXPECT_EQ(where({"global.linear_solvr=dense_qr"}), "global.linear_solvr");
  EXPECT_EQ(where({"global.linear_solver=cholmod"}), "global.linear_solver");
  EXPECT_EQ(where({"global.potential=gvf"}), "global.potential");
  EXPECT_EQ(where({"global.max_trust_region_radius=0.5"}), "global.max_trust_region_radius");
  EXPECT_EQ(where({"phases[0].weights=[1, 1]"}), "phases[0].weights");
  EXPECT_EQ(where({"phases[0].weights=[0, 0, 0]"}), "phases[0].weights");
  EXPECT_EQ(where({"phases[0].weights=[1, -1, 1]"}), "phases[0].weights");
  EXPECT_EQ(where({"phases[0].weights=[0, 1, 1]"}), "(accepted)");
  EXPECT_EQ(where({"solver=global"}), "(accepted)");
}

}  // namespace
}  // namespace dsnake
