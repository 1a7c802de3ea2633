// The limits a run keeps, end to end through the dsnake command: a remeshing length that would
// need more vertices than watchdog.max_vertices is refused when the experiment is assembled
// (one line naming the key, exit code 2, nothing written); a global solve that runs away or
// past global.max_time_s stops (exit code 3, one line); a snake that collapses is stopped at
// the iteration where its enclosed volume falls below watchdog.min_size of the placed
// template's, with the last good state written (exit code 3, one line naming phase and
// iteration). Each stops where it says (the iteration, the assembly), which is what bounds its
// time; the wall times are measured as whole processes (docs/usage.md, the watchdog).
#include "experiments/spec/builtin.h"
#include "framework/io/mesh_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

struct Outcome {
  int exit_code = -1;
  std::string err;
  int lines() const { return static_cast<int>(std::count(err.begin(), err.end(), '\n')); }
  bool says(const std::string& fragment) const { return err.find(fragment) != std::string::npos; }
};

class RunLimitsTest : public test_support::TempDirTest {
 protected:
  // `dsnake ARGS` with stderr captured.
  Outcome dsnake(const std::string& args) {
    const fs::path err = dir_ / "stderr.txt";
    const int status = std::system((std::string(DSNAKE_EXE) + " " + args + " 2>" + err.string()).c_str());
    Outcome o;
    o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    o.err = slurp(err);
    return o;
  }
  // A run that must be refused: exit code 2, one line naming `key` (and `fragments`), no output.
  void expect_refused(const std::string& run_args, const std::string& key, const std::vector<std::string>& fragments = {}) {
    const fs::path out = dir_ / "refused";
    const Outcome o = dsnake("run " + run_args + " --out " + out.string());
    EXPECT_EQ(o.exit_code, 2) << run_args << ": " << o.err;
    EXPECT_EQ(o.lines(), 1) << run_args << ": " << o.err;
    EXPECT_TRUE(o.says(key)) << run_args << ": missing \"" << key << "\" in " << o.err;
    for (const auto& f : fragments) EXPECT_TRUE(o.says(f)) << run_args << ": missing \"" << f << "\" in " << o.err;
    EXPECT_FALSE(fs::exists(out)) << run_args;
  }
};

// The volume a snapshot or output mesh encloses (3D; the VTK files dsnake writes).
double enclosed_volume(const fs::path& vtk) {
  const Template<3> t = read_shape<3>(vtk.string());
  return signed_measure<3>(t.positions, t.connectivity);
}

// Every remeshing length of every stage, 2D and 3D: a length that would need more vertices than
// the budget for the placed template is refused at assembly, naming the stage's key; lengths
// that never add vertices (a stage's min_edge, simplify's max_edge) are not.
TEST_F(RunLimitsTest, ARemeshingLengthPastTheVertexBudgetIsRefusedNamingItsKey) {
  // 2D resample (the built-in classical snake's refine phase): 2e-6 mm on a 276 mm circle, 1.4e8 vertices.
  expect_refused("builtin:classical --set 'phases[1].remesh[0].max_edge=2e-6' --set 'phases[1].remesh[0].min_edge=1e-6'",
                 "builtin:classical: phases[1].remesh[0].max_edge: 2e-06 mm would need about 1.4e+08 vertices",
                 {"watchdog.max_vertices 1000000", "use at least 0.000276 mm"});
  // A length past double's reach (the estimate is infinite) is refused the same way.
  expect_refused("builtin:classical --set 'phases[1].remesh[0].max_edge=1e-320' --set 'phases[1].remesh[0].min_edge=4e-321'",
                 "phases[1].remesh[0].max_edge");
  // The budget is the watchdog's: the classical snake's own 2 mm needs 138 vertices, more than 100.
  expect_refused("builtin:classical --set watchdog.max_vertices=100", "phases[1].remesh[0].max_edge",
                 {"watchdog.max_vertices 100)"});
  // 3D refine on the ellipsoid's sphere (area 9117 mm^2): 1e-3 mm needs 9117 / (sqrt(3) / 2 * 1e-6) = 1.05e10;
  // with a schedule the final max_edge is the one that counts.
  expect_refused("builtin:ellipsoid --set 'phases[0].remesh=[{\"type\": \"uniform\"}, {\"type\": \"refine\", \"max_edge\": 1e-3}]'",
                 "builtin:ellipsoid: phases[0].remesh[1].max_edge: 0.001 mm would need about 1.1e+10 vertices",
                 {"(area 9117 mm^2"});
  expect_refused("builtin:ellipsoid --set 'phases[0].remesh=[{\"type\": \"refine\", \"max_edge\": 0.01, \"start_max_edge\": 5}]'",
                 "phases[0].remesh[0].max_edge");
  // Lengths that only remove or keep vertices: accepted however small.
  for (const std::string stages :
       {"[{\"type\": \"simplify\", \"min_edge\": 1e-300, \"max_edge\": 1e-299}, {\"type\": \"refine\", \"max_edge\": 3}]",
        "[{\"type\": \"uniform\"}, {\"type\": \"delaunay\"}]"}) {
    const Outcome o = dsnake("validate builtin:ellipsoid --set 'phases[0].remesh=" + stages + "'");
    EXPECT_EQ(o.exit_code, 0) << stages << ": " << o.err;
  }
  const Outcome tiny_min = dsnake("validate builtin:classical --set 'phases[1].remesh[0].min_edge=1e-300'");
  EXPECT_EQ(tiny_min.exit_code, 0) << tiny_min.err;
}

// A global solve whose external term outweighs the rest by 1e12 (tau and weight 1e12): its first
// Levenberg-Marquardt step throws vertices hundreds of metres; without the watchdog on the global
// solve, the next phase would resample that contour into 2.1 million vertices and run past 60 s.
// Expected: diverged at that iteration, one line, the last good state (the start) written.
TEST_F(RunLimitsTest, AGlobalSolveThatRunsAwayStopsAtOnce) {
  const fs::path out = dir_ / "global";
  const Outcome o = dsnake("run builtin:classical --set solver=global --set 'energies[1].tau=1e12' "
                           "--set 'energies[1].weight=1e12' --quiet --out " + out.string());
  EXPECT_EQ(o.exit_code, 3) << o.err;
  EXPECT_EQ(o.lines(), 1) << o.err;
  EXPECT_TRUE(o.says("the run diverged in phase fit at iteration 1: a vertex moved more than watchdog.max_move")) << o.err;
  const auto result = nlohmann::json::parse(slurp(out / "result.json"));
  EXPECT_EQ(result["status"], "diverged");
  EXPECT_EQ(result["divergence"]["term"], "global");
  EXPECT_EQ(result["vertices"]["final"], 64);
  const std::string final_txt = slurp(out / "final.txt");
  EXPECT_EQ(final_txt, slurp(out / "initial.txt"));  // iteration 1 failed: the start is the last good state
}

// A snake step whose proposals run away under the collision guard (the external step 1e9 on the
// sphere example): the watchdog sees the proposed moves, not the guard's shortened ones. Otherwise
// the guard would shorten every step to nothing, each iteration testing every pair of facets, and
// the run would go on for minutes with "max move 0".
TEST_F(RunLimitsTest, AGuardedSnakeThatRunsAwayStopsAtOnce) {
  const fs::path out = dir_ / "guarded";
  const std::string file = std::string(DSNAKE_SOURCE_DIR) + "/experiments/examples/dsnake_sphere_to_ellipsoid.json";
  // (a gradient field and coarse metrics samples: the cheapest; the step runs away at once whatever they are)
  const Outcome o = dsnake("run " + file + " --set 'energies[1].tau=1e9' --set 'field={\"type\": \"gradient\", \"sigma\": 1}' --set metrics.sample_spacing=1 --quiet --out " +
                           out.string());
  EXPECT_EQ(o.exit_code, 3) << o.err;
  EXPECT_EQ(o.lines(), 1) << o.err;
  EXPECT_TRUE(o.says("a vertex moved more than watchdog.max_move")) << o.err;
  const auto result = nlohmann::json::parse(slurp(out / "result.json"));
  EXPECT_EQ(result["divergence"]["term"], "energies[1] (external)");
  EXPECT_EQ(result["divergence"]["phase_iteration"], 1);  // the first step's proposals already ran away
}

// global.max_time_s: a bound of a millisecond stops the solve after its first iterations, as
// diverged, naming the key; global.max_iterations bounds each solve's Ceres iterations.
TEST_F(RunLimitsTest, TheGlobalSolveKeepsItsTimeAndIterationBounds) {
  const fs::path out = dir_ / "timed";
  const std::string puzzle = std::string(DSNAKE_SOURCE_DIR) + "/experiments/ablation/global/puzzle_2d.json";
  const Outcome timed = dsnake("run " + puzzle + " --set solver=global --set global.max_time_s=0.001 --quiet --out " +
                               out.string());
  EXPECT_EQ(timed.exit_code, 3) << timed.err;
  EXPECT_EQ(timed.lines(), 1) << timed.err;
  EXPECT_TRUE(timed.says("reached global.max_time_s (0.001 s)")) << timed.err;
  const auto r = nlohmann::json::parse(slurp(out / "result.json"));
  EXPECT_EQ(r["divergence"]["term"], "global");
  const Outcome few = dsnake("run " + puzzle + " --set solver=global --set global.max_iterations=5 --quiet --out " +
                             (dir_ / "few").string());
  EXPECT_EQ(few.exit_code, 0) << few.err;
  const auto f = nlohmann::json::parse(slurp(dir_ / "few" / "result.json"));
  EXPECT_EQ(f["iterations"].get<int>(), 5);
  EXPECT_LE(f["global"]["solves"][0][0]["iterations"].get<int>(), 6);  // (Ceres also counts the step it stopped on)
}

// A coarse sphere (162 vertices) under a strong tension shrinks to a point. Without the check
// (min_size 0) every iteration is written as a snapshot: the first whose enclosed volume is below
// 1e-3 of the placed template's is k. With the default min_size the run stops at k: exit code 3,
// one line naming the phase and the iteration, result.json's divergence names the collapse, its
// share and k, and the outputs are iteration k - 1's state.
TEST_F(RunLimitsTest, ACollapseIsReportedAtTheIterationItHappensWithTheLastGoodState) {
  const std::string collapse = "run builtin:ellipsoid --set template.subdivisions=2 --set 'energies[0].alpha=50' "
                               "--set output.figures=false --set output.result_mask=false --quiet ";
  const fs::path traced = dir_ / "traced";
  const Outcome free = dsnake(collapse + "--set watchdog.min_size=0 --set output.snapshot_every=1 "
                                         "--set 'phases[0].iterations=40' --out " + traced.string());
  ASSERT_TRUE(free.exit_code == 0 || free.exit_code == 3) << free.err;  // (max_move may stop the point later)
  const double start = enclosed_volume(traced / "initial.vtk");
  ASSERT_GT(start, 0);
  int k = 0;
  double share_k = 0;
  char name[64];
  for (int it = 1; it <= 40 && k == 0; ++it) {
    std::snprintf(name, sizeof name, "iteration_%06d.vtk", it);
    const double share = enclosed_volume(traced / "snapshots" / name) / start;
    if (share < 1e-3) k = it, share_k = share;
  }
  ASSERT_GT(k, 1) << "the tension did not collapse the sphere within 40 iterations";

  const fs::path out = dir_ / "collapsed";
  const Outcome o = dsnake(collapse + "--out " + out.string());
  EXPECT_EQ(o.exit_code, 3) << o.err;
  EXPECT_EQ(o.lines(), 1) << o.err;
  EXPECT_TRUE(o.says("the run diverged in phase fit at iteration " + std::to_string(k) + ": the snake collapsed"))
      << "k = " << k << ": " << o.err;
  EXPECT_TRUE(o.says("watchdog.min_size")) << o.err;
  const auto result = nlohmann::json::parse(slurp(out / "result.json"));
  EXPECT_EQ(result["status"], "diverged");
  const auto& d = result["divergence"];
  EXPECT_EQ(d["phase"], "fit");
  EXPECT_EQ(d["phase_iteration"], k);
  EXPECT_NE(d["reason"].get<std::string>().find("collapsed"), std::string::npos) << d.dump();
  EXPECT_NEAR(d["size_share"].get<double>(), share_k, 1e-6 * std::abs(share_k) + 1e-12);
  EXPECT_EQ(d["term"], "energies[0] (internal)");
  // The outputs hold iteration k - 1's positions, which passed.
  std::snprintf(name, sizeof name, "iteration_%06d.vtk", k - 1);
  const Template<3> last_good = read_shape<3>((traced / "snapshots" / name).string());
  const Template<3> written = read_shape<3>((out / "final.vtk").string());
  ASSERT_EQ(written.positions.size(), last_good.positions.size());
  for (size_t v = 0; v < written.positions.size(); ++v)
    EXPECT_NEAR((written.positions[v] - last_good.positions[v]).norm(), 0, 1e-9) << v;
  EXPECT_GE(enclosed_volume(out / "final.vtk") / start, 1e-3);
}

// The new keys' bad values: one line naming the file and the key, exit code 2, nothing written.
TEST_F(RunLimitsTest, BadValuesOfTheNewKeysNameTheKey) {
  for (const std::string v : {"-0.1", "1", "2", "\\\"x\\\"", "true"})
    expect_refused("builtin:ellipsoid --set watchdog.min_size=" + v, "builtin:ellipsoid: watchdog.min_size");
  for (const std::string v : {"0", "-5", "1e8", "\\\"x\\\""})
    expect_refused("builtin:default --set solver=global --set global.max_time_s=" + v, "builtin:default: global.max_time_s");
  auto j = nlohmann::json::parse(builtin_experiment_text("default"));
  j["watchdog"] = {{"min_size", -1}};
  const fs::path file = dir_ / "exp.json";
  std::ofstream(file) << j.dump();
  expect_refused(file.string(), "exp.json: watchdog.min_size");
}

}  // namespace
}  // namespace dsnake
