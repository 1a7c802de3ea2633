// dsnake sweep: expansion and ids, the aggregates from hand-made results, and the command
// (parallel runs, skip on rerun, resume after a kill, GNU parallel and Slurm manifests, bad
// sweep files) on tiny 2D experiments.
#include "experiments/sweep/sweep.h"
#include "experiments/sweep/sweep_summary.h"
#include "framework/core/errors.h"
#include "framework/io/image_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// A circle registered to a blurred square on a 64^2 image: a run takes a few milliseconds.
json tiny_experiment(int iterations = 40) {
  return {{"name", "tiny"},
          {"dimension", 2},
          {"seed", 1},
          {"image", {{"phantom", "square"}, {"size", {64, 64}}, {"half_width", 16}, {"blur", 1.5}}},
          {"template", {{"phantom", "circle"}, {"radius", 22}, {"vertices", 32}, {"center", {31.5, 31.5}}}},
          {"field", {{"type", "gradient"}, {"sigma", 2.0}}},
          {"energies", {{{"type", "internal"}, {"weight", 1.0}, {"alpha", 0.1}, {"beta", 0.01}},
                        {{"type", "external"}, {"weight", 1.0}, {"tau", 3.0}}}},
          {"phases", {{{"name", "fit"}, {"iterations", iterations}, {"tolerance", 0.0}}}},
          {"success", {{"mean_surface_distance", 1.0}, {"dice", 0.9}, {"self_intersections", 0}}},
          {"output", {{"figures", false}}}};
}

// The example sweep file of experiments/sweep/sweep.h, on the tiny experiment.
const char* kExampleSweep = R"({
  "description": "two methods x two alphas x three corruption levels x two seeds",
  "base": "exp.json",
  "grid": {"energies[0].alpha": [0.1, 0.3]},
  "corruptions": [[], [{"type": "outliers", "fraction": 0.05}], [{"type": "noise", "sigma": 30}]],
  "seeds": {"count": 2, "first": 4},
  "methods": {"snake": {}, "stiff": {"overrides": {"energies[0].beta": 0.1}}}
})";

struct CommandResult {
  int exit_code = -1;
  std::string err;
};

class SweepTest : public test_support::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    write("exp.json", tiny_experiment().dump(2));
  }

  fs::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
  CommandResult shell(const std::string& cmd) {
    const fs::path err = dir_ / "stderr.txt";
    const int status = std::system((cmd + " >" + (dir_ / "stdout.txt").string() + " 2>" + err.string()).c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(err)};
  }
  CommandResult dsnake(const std::string& args) { return shell(std::string(DSNAKE_EXE) + " " + args); }

  // CSV rows as field lists (no quoted commas in these tests), header first.
  static std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
    std::vector<std::vector<std::string>> rows;
    std::istringstream in(slurp(p));
    for (std::string line; std::getline(in, line);) {
      std::vector<std::string> fields;
      std::string f;
      std::istringstream l(line);
      while (std::getline(l, f, ',')) fields.push_back(f);
      if (!line.empty() && line.back() == ',') fields.emplace_back();
      rows.push_back(fields);
    }
    return rows;
  }
  static int column(const std::vector<std::string>& header, const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? -1 : int(it - header.begin());
  }
  // Every published run's result.json modification time, by id (staging folders excluded).
  static std::map<std::string, fs::file_time_type> finished_runs(const fs::path& out) {
    std::map<std::string, fs::file_time_type> m;
    if (!fs::exists(out / "runs")) return m;
    for (const auto& e : fs::directory_iterator(out / "runs"))
      if (e.path().filename().string().find(".partial-") == std::string::npos && fs::exists(e.path() / "result.json")) m[e.path().filename().string()] = fs::last_write_time(e.path() / "result.json");
    return m;
  }
  static int count_lines(const std::string& s, const std::string& fragment) {
    int n = 0;
    std::istringstream in(s);
    for (std::string line; std::getline(in, line);) n += line.find(fragment) != std::string::npos;
    return n;
  }
};

TEST_F(SweepTest, ExpandsTheCartesianProductInOrderWithStableIds) {
  const fs::path file = write("sweep.json", kExampleSweep);
  const Sweep sweep = load_sweep(file.string());
  ASSERT_EQ(sweep.runs.size(), 2u * 2u * 3u * 2u);
  ASSERT_EQ(sweep.grid_keys, std::vector<std::string>{"energies[0].alpha"});
  std::set<std::string> ids;
  for (size_t i = 0; i < sweep.runs.size(); ++i) {
    const SweepRun& r = sweep.runs[i];
    ids.insert(r.id);
    // Method-major, then grid point, level, seed.
    const int m = int(i / 12), g = int(i / 6 % 2), l = int(i / 2 % 3), s = int(i % 2);
    EXPECT_EQ(r.method, m == 0 ? "snake" : "stiff");
    EXPECT_EQ(r.grid_point, g);
    EXPECT_EQ(r.corruption_level, l);
    EXPECT_EQ(r.seed, 4u + s);
    const std::string prefix = r.method + "-g" + std::to_string(g) + "-c" + std::to_string(l) + "-s" + std::to_string(4 + s) + "-";
    EXPECT_EQ(r.id.rfind(prefix, 0), 0u) << r.id;
    EXPECT_EQ(r.id.size(), prefix.size() + 8);
    // The resolved document carries every override.
    EXPECT_DOUBLE_EQ(r.config["energies"][0]["alpha"].get<double>(), g == 0 ? 0.1 : 0.3);
    EXPECT_DOUBLE_EQ(r.config["energies"][0]["beta"].get<double>(), m == 0 ? 0.01 : 0.1);
    EXPECT_EQ(r.config["seed"].get<int>(), 4 + s);
    EXPECT_EQ(r.config["corruption"], json::parse(kExampleSweep)["corruptions"][l]);
    EXPECT_EQ(r.corruption, r.config["corruption"]);
    ASSERT_EQ(r.parameters.size(), 1u);
    EXPECT_EQ(r.parameters[0].second, r.config["energies"][0]["alpha"]);
    // Named by its method, the base named in its description.
    EXPECT_EQ(r.config["name"], r.method);
    EXPECT_EQ(r.config["description"], "Method \"" + r.method + "\" of the sweep sweep.json (base: tiny)");
  }
  EXPECT_EQ(ids.size(), sweep.runs.size());
  EXPECT_EQ(sweep.runs[15].label(), "stiff/energies[0].alpha=0.1/outliers=0.05/seed=5");

  // The same file gives the same ids; a changed grid value changes exactly its runs' ids.
  const Sweep again = load_sweep(file.string());
  for (size_t i = 0; i < sweep.runs.size(); ++i) EXPECT_EQ(again.runs[i].id, sweep.runs[i].id);
  json edited = json::parse(kExampleSweep);
  edited["grid"]["energies[0].alpha"][1] = 0.4;
  write("sweep.json", edited.dump());
  const Sweep changed = load_sweep(file.string(), false);
  int differing = 0;
  for (size_t i = 0; i < sweep.runs.size(); ++i) {
    differing += changed.runs[i].id != sweep.runs[i].id;
    EXPECT_EQ(changed.runs[i].id != sweep.runs[i].id, sweep.runs[i].grid_point == 1) << i;
  }
  EXPECT_EQ(differing, 12);
}

TEST_F(SweepTest, WithoutOptionalKeysOneRunOfTheBaseAndAbsolutePaths) {
  // A template from a file, relative to the experiment in a sub-folder: the resolved document
  // names it by an absolute path, so configs/<id>.json runs from anywhere.
  fs::create_directories(dir_ / "sub");
  std::string contour;
  for (int k = 0; k < 32; ++k)
    contour += std::to_string(31.5 + 22 * std::cos(2 * M_PI * k / 32)) + " " + std::to_string(31.5 + 22 * std::sin(2 * M_PI * k / 32)) + "\n";
  write("sub/circle.txt", contour);
  json e = tiny_experiment();
  e["template"] = {{"file", "circle.txt"}};
  e["seed"] = 9;
  write("sub/exp.json", e.dump());
  const Sweep sweep = load_sweep(write("sweep.json", R"({"base": "sub/exp.json"})").string());
  ASSERT_EQ(sweep.runs.size(), 1u);
  const SweepRun& r = sweep.runs[0];
  EXPECT_EQ(r.method, "");
  EXPECT_EQ(r.seed, 9u);
  EXPECT_EQ(r.corruption, json::array());
  EXPECT_EQ(r.id.rfind("g0-c0-s9-", 0), 0u) << r.id;
  EXPECT_EQ(r.label(), "clean/seed=9");
  const fs::path tmpl = r.config["template"]["file"].get<std::string>();
  EXPECT_TRUE(tmpl.is_absolute());
  EXPECT_TRUE(fs::equivalent(tmpl, dir_ / "sub" / "circle.txt"));
}

TEST_F(SweepTest, BadSweepFilesNameTheFileAndTheJsonPath) {
  const json good = json::parse(kExampleSweep);
  auto expect_error = [&](const std::function<void(json&)>& edit, const std::vector<std::string>& fragments) {
    json j = good;
    edit(j);
    const fs::path file = write("bad.json", j.dump());
    try {
      load_sweep(file.string());
      ADD_FAILURE() << "no error for " << j.dump();
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(file.string(), 0), 0u) << what;
      for (const auto& f : fragments) EXPECT_NE(what.find(f), std::string::npos) << "missing \"" << f << "\" in: " << what;
    }
  };
  expect_error([](json& j) { j["seedz"] = 1; }, {"seedz", "unknown key"});
  expect_error([](json& j) { j.erase("base"); }, {"base", "is required"});
  expect_error([](json& j) { j["grid"]["energies[0].alpha"] = 0.1; }, {"grid.energies[0].alpha", "non-empty array"});
  expect_error([](json& j) { j["methods"]["snake"]["overides"] = json::object(); }, {"methods.snake.overides", "unknown key"});
  expect_error([](json& j) { j["methods"]["a/b"] = json::object(); }, {"methods.a/b"});
  expect_error([](json& j) { j["seeds"] = {1, 2, 1}; }, {"seeds", "twice"});
  expect_error([](json& j) { j["seeds"] = {1, -2}; }, {"seeds[1]", "non-negative"});
  expect_error([](json& j) { j["seeds"] = json::parse(R"({"count": 0})"); }, {"seeds.count", "must be in"});
  expect_error([](json& j) { j["corruptions"][1] = json::parse(R"({"type": "outliers"})"); }, {"corruptions[1]", "list"});
  expect_error([](json& j) { j["success"] = 1; }, {"success", "object"});
  // Overrides that do not fit the experiment: the grid key, then the run and the experiment's path.
  expect_error([](json& j) { j["grid"] = json::parse(R"({"energies[5].alpha": [0.1]})"); }, {"grid.energies[5].alpha", "out of range"});
  expect_error([](json& j) { j["grid"]["energies[0].alpha"] = json::parse("[0.1, -1]"); },
               {"run snake-g1-c0-s4-", "exp.json", "energies[0].alpha", "must be"});
  expect_error([](json& j) { j["corruptions"][2] = json::parse(R"([{"type": "noize"}])"); }, {"corruptions[2]", "corruption[0].type", "noize"});
  expect_error([](json& j) { j["methods"]["stiff"]["base"] = "no_such.json"; }, {"methods.stiff", "no_such.json"});
  // A grid of 10^10 points is refused before it is expanded (expanding it would hang), and so is a
  // product of methods, grid points, levels and seeds above 100 000 runs.
  expect_error([](json& j) {
    j["grid"] = json::object();
    for (int k = 0; k < 10; ++k) j["grid"]["phases[0].iterations" + std::string(k, ' ')] = json::array({1, 2, 3, 4, 5, 6, 7, 8, 9, 10});
  }, {"grid", "more than 100000"});
  expect_error([](json& j) { j["seeds"] = json::parse(R"({"count": 100000})"); }, {"grid", "runs, more than 100000"});
}

// Hand-made results: results[i] for sweep.runs[i], success by method, level and seed.
std::vector<std::optional<json>> hand_made(const Sweep& sweep,
                                           const std::function<std::optional<bool>(const SweepRun&)>& success) {
  std::vector<std::optional<json>> results;
  for (const auto& run : sweep.runs) {
    const auto s = success(run);
    if (s) results.push_back(json{{"success", *s}, {"status", "converged"}});
    else results.push_back(std::nullopt);
  }
  return results;
}

TEST_F(SweepTest, BreakdownFromHandMadeResults) {
  // Levels listed out of order on purpose: the breakdown follows the severity.
  const fs::path file = write("sweep.json", R"({"base": "exp.json",
    "corruptions": [[], [{"type": "outliers", "fraction": 0.01}], [{"type": "outliers", "fraction": 0.03}],
                    [{"type": "noise", "sigma": 35}], [{"type": "noise", "sigma": 30}]],
    "seeds": {"count": 4}, "methods": {"a": {}, "b": {}}})");
  const Sweep sweep = load_sweep(file.string(), false);
  // Successes out of 4 seeds (-1: that many seeds unfinished), per method and level.
  const std::map<std::string, std::vector<int>> successes = {{"a", {4, 3, 1, 2, 4}}, {"b", {4, 1, 2, 0, 0}}};
  const auto results = hand_made(sweep, [&](const SweepRun& r) -> std::optional<bool> {
    if (r.method == "b" && r.corruption_level == 2 && r.seed == 3) return std::nullopt;  // 2 of 3 finished
    if (r.method == "b" && r.corruption_level == 4) return std::nullopt;                 // none finished
    return int(r.seed) < successes.at(r.method)[r.corruption_level];
  });
  const fs::path csv = dir_ / "breakdown.csv";
  std::ofstream(csv) << breakdown_csv(sweep, results);
  const auto rows = read_csv(csv);
  ASSERT_EQ(rows.size(), 1u + 2 * (3 + 3));
  EXPECT_EQ(rows[0], (std::vector<std::string>{"method", "grid", "corruption_type", "level", "corruption", "magnitude",
                                               "runs", "finished", "successes", "success_rate", "breakdown"}));
  using R = std::vector<std::string>;
  // Method a: outliers break down at 3% (1/4 < 50%); noise never (35: 2/4 is not below 50%).
  EXPECT_EQ(rows[1], (R{"a", "", "outliers", "0", "clean", "0", "4", "4", "4", "1", "outliers=0.03"}));
  EXPECT_EQ(rows[2], (R{"a", "", "outliers", "1", "outliers=0.01", "0.01", "4", "4", "3", "0.75", "outliers=0.03"}));
  EXPECT_EQ(rows[3], (R{"a", "", "outliers", "2", "outliers=0.03", "0.03", "4", "4", "1", "0.25", "outliers=0.03"}));
  EXPECT_EQ(rows[4], (R{"a", "", "noise", "0", "clean", "0", "4", "4", "4", "1", "none"}));
  EXPECT_EQ(rows[5], (R{"a", "", "noise", "4", "noise=30", "30", "4", "4", "4", "1", "none"}));
  EXPECT_EQ(rows[6], (R{"a", "", "noise", "3", "noise=35", "35", "4", "4", "2", "0.5", "none"}));
  // Method b: outliers at 1%; noise 30 has no finished run, so its breakdown is open.
  EXPECT_EQ(rows[8], (R{"b", "", "outliers", "1", "outliers=0.01", "0.01", "4", "4", "1", "0.25", "outliers=0.01"}));
  EXPECT_EQ(rows[9], (R{"b", "", "outliers", "2", "outliers=0.03", "0.03", "4", "3", "2", "0.6666666667", "outliers=0.01"}));
  EXPECT_EQ(rows[11], (R{"b", "", "noise", "4", "noise=30", "30", "4", "0", "0", "", "incomplete"}));
  EXPECT_EQ(rows[12], (R{"b", "", "noise", "3", "noise=35", "35", "4", "4", "0", "0", "incomplete"}));

  // A failing clean level is the breakdown itself.
  const auto clean_fails = hand_made(sweep, [](const SweepRun& r) -> std::optional<bool> { return r.seed == 0; });
  EXPECT_NE(breakdown_csv(sweep, clean_fails).find("a,,outliers,0,clean,0,4,4,1,0.25,clean\n"), std::string::npos);
}

TEST_F(SweepTest, ResultsCsvHasOneRowPerRunWithItsValues) {
  const Sweep sweep = load_sweep(write("sweep.json", kExampleSweep).string(), false);
  std::vector<std::optional<json>> results(sweep.runs.size());
  results[3] = json::parse(R"({"success": true, "status": "converged", "iterations": 37,
    "metrics": {"mean_surface_distance": 0.25, "hausdorff95": 0.5, "hausdorff": 0.75, "dice": 0.96875,
                "correspondence_error_mean": null, "correspondence_error_max": null, "self_intersections": 0},
    "vertices": {"initial": 32, "final": 40, "deformation": 32},
    "timings": {"field_s": 0.5, "evolve_s": 1.5, "metrics_s": 0.125, "total_s": 2.25}})");
  const fs::path csv = dir_ / "results.csv";
  std::ofstream(csv) << results_csv(sweep, results);
  const auto rows = read_csv(csv);
  ASSERT_EQ(rows.size(), 1 + sweep.runs.size());
  const std::vector<std::string> header = {
      "run_id", "method", "energies[0].alpha", "corruption_level", "corruption", "seed", "status", "success",
      "mean_surface_distance", "hausdorff95", "hausdorff", "dice", "correspondence_error_mean",
      "correspondence_error_max", "self_intersections", "vertices_initial", "vertices_final",
      "vertices_deformation", "iterations", "field_s", "evolve_s", "metrics_s", "total_s", "build", "stale"};
  EXPECT_EQ(rows[0], header);
  const SweepRun& r = sweep.runs[3];
  EXPECT_EQ(rows[4], (std::vector<std::string>{r.id, "snake", "0.1", "1", "outliers=0.05", "5", "converged", "true", "0.25",
                                               "0.5", "0.75", "0.96875", "", "", "0", "32", "40", "32", "37", "0.5",
                                               "1.5", "0.125", "2.25", "", ""}));
  for (size_t i = 0; i < sweep.runs.size(); ++i) {
    ASSERT_EQ(rows[1 + i].size(), header.size()) << i;
    EXPECT_EQ(rows[1 + i][0], sweep.runs[i].id);
    if (i != 3) {
      EXPECT_EQ(rows[1 + i][6], "missing");
    }
  }
}

// The command: -j 2 runs every run once, results.csv matches each result.json, a rerun skips.
TEST_F(SweepTest, CommandRunsInParallelAggregatesAndSkipsOnRerun) {
  const fs::path file = write("sweep.json", R"({"base": "exp.json",
    "corruptions": [[], [{"type": "outliers", "fraction": 0.02}]], "seeds": [0, 1],
    "methods": {"snake": {}, "stiff": {"overrides": {"energies[0].alpha": 0.3}}}})");
  const fs::path out = dir_ / "out";
  const CommandResult first = dsnake("sweep " + file.string() + " --out " + out.string() + " -j 2");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_EQ(count_lines(first.err, "/8] "), 8) << first.err;
  EXPECT_NE(first.err.find("[8/8] "), std::string::npos) << first.err;
  const Sweep sweep = load_sweep(file.string(), false);
  const auto done = finished_runs(out);
  ASSERT_EQ(done.size(), 8u);
  const auto rows = read_csv(out / "results.csv");
  ASSERT_EQ(rows.size(), 9u);
  const int id = column(rows[0], "run_id"), success = column(rows[0], "success"), dice = column(rows[0], "dice"),
            seed = column(rows[0], "seed");
  int successes = 0;
  for (size_t i = 0; i < sweep.runs.size(); ++i) {
    EXPECT_EQ(rows[1 + i][id], sweep.runs[i].id);
    const json result = json::parse(slurp(out / "runs" / sweep.runs[i].id / "result.json"));
    EXPECT_EQ(rows[1 + i][success], result["success"].get<bool>() ? "true" : "false");
    EXPECT_NEAR(std::stod(rows[1 + i][dice]), result["metrics"]["dice"].get<double>(), 1e-9);
    EXPECT_EQ(result["config"]["seed"].get<int>(), std::stoi(rows[1 + i][seed]));
    EXPECT_EQ(result["config"]["corruption"], sweep.runs[i].corruption);
    successes += result["success"].get<bool>();
  }
  EXPECT_GE(successes, 4) << "the clean tiny runs register the square";
  EXPECT_EQ(read_csv(out / "breakdown.csv").size(), 1u + 2 * 2);
  // The runs' corrupted phantoms are not kept (output.image "never" unless the experiment asks).
  for (const auto& run : load_sweep(file.string(), false).runs) {
    EXPECT_EQ(run.config["output"]["image"], "never");
    EXPECT_TRUE(fs::exists(out / "runs" / run.id / "result.json"));
    EXPECT_FALSE(fs::exists(out / "runs" / run.id / "image.nii.gz")) << run.id;
  }
  EXPECT_EQ(slurp(out / "summary.csv"), summary_tables(slurp(out / "results.csv"), (out / "results.csv").string()).csv);

  const CommandResult again = dsnake("sweep " + file.string() + " --out " + out.string() + " -j 2");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.err.find("8 runs, 8 finished already (skipped), running 0"), std::string::npos) << again.err;
  EXPECT_EQ(finished_runs(out), done) << "a finished run was run again";
  EXPECT_EQ(read_csv(out / "results.csv"), rows);
}

// A sweep killed (SIGKILL) after its first result, then resumed: every run finishes exactly
// once, the finished ones are not rerun, and no staging folder is left.
TEST_F(SweepTest, KilledSweepResumesWithEveryRunExactlyOnce) {
  write("exp.json", tiny_experiment(1500).dump(2));
  const fs::path file = write("sweep.json", R"({"base": "exp.json", "seeds": {"count": 12}})");
  const fs::path out = dir_ / "out";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int null_fd = ::open("/dev/null", O_WRONLY);
    ::dup2(null_fd, 2);
    ::execl(DSNAKE_EXE, DSNAKE_EXE, "sweep", file.c_str(), "--out", out.c_str(), "-j", "2", (char*)nullptr);
    ::_exit(127);
  }
  const auto start = std::chrono::steady_clock::now();
  while (finished_runs(out).empty() && std::chrono::steady_clock::now() - start < std::chrono::seconds(60))
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  const auto before = finished_runs(out);
  ASSERT_GE(before.size(), 1u);
  ASSERT_LT(before.size(), 12u) << "the sweep finished before it was killed: make the runs longer";

  const CommandResult resumed = dsnake("sweep " + file.string() + " --out " + out.string() + " -j 2");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  const auto after = finished_runs(out);
  EXPECT_EQ(after.size(), 12u);
  for (const auto& [id, mtime] : before) EXPECT_EQ(after.at(id), mtime) << id << " was run again";
  // The resumed sweep ran exactly the unfinished ones (the killed ones possibly half-published).
  EXPECT_EQ(count_lines(resumed.err, "/12] "), int(12 - before.size())) << resumed.err;
  for (const auto& e : fs::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();
  const Sweep sweep = load_sweep(file.string(), false);
  const auto rows = read_csv(out / "results.csv");
  ASSERT_EQ(rows.size(), 13u);
  std::set<std::string> ids;
  for (size_t i = 1; i < rows.size(); ++i) {
    ids.insert(rows[i][0]);
    EXPECT_NE(rows[i][column(rows[0], "status")], "missing");
  }
  EXPECT_EQ(ids.size(), 12u);
}

// The children of a process, from /proc/<pid>/stat ("pid (comm) state ppid ...").
std::vector<pid_t> children_of(pid_t parent) {
  std::vector<pid_t> children;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(e.path() / "stat");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto close = text.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(text.substr(close + 2));
    char state = 0;
    long ppid = 0;
    rest >> state >> ppid;
    if (ppid == parent && state != 'Z') children.push_back(static_cast<pid_t>(std::stol(name)));
  }
  return children;
}

// A run whose process dies is reported, counted as failed (exit code 1, "missing" in the
// table), the other runs go on, and a rerun runs only that one.
TEST_F(SweepTest, AFailedRunIsReportedAndRetriedOnRerun) {
  write("exp.json", tiny_experiment(20000).dump(2));
  const fs::path file = write("sweep.json", R"({"base": "exp.json", "seeds": [0, 1]})");
  const fs::path out = dir_ / "out", err = dir_ / "sweep_stderr.txt";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 2);
    ::execl(DSNAKE_EXE, DSNAKE_EXE, "sweep", file.c_str(), "--out", out.c_str(), "-j", "1", (char*)nullptr);
    ::_exit(127);
  }
  std::vector<pid_t> children;
  const auto start = std::chrono::steady_clock::now();
  while ((children = children_of(pid)).empty() && std::chrono::steady_clock::now() - start < std::chrono::seconds(60))
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ASSERT_EQ(children.size(), 1u);
  ::kill(children[0], SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1) << slurp(err);
  const Sweep sweep = load_sweep(file.string(), false);
  const std::string text = slurp(err);
  EXPECT_NE(text.find("[1/2] clean/seed=0: run failed (killed by signal 9; " + (out / "logs" / (sweep.runs[0].id + ".log")).string()),
            std::string::npos) << text;
  EXPECT_NE(text.find("2 runs: 0 skipped, 1 finished, 1 process failed (logs/)"), std::string::npos) << text;
  EXPECT_EQ(finished_runs(out).size(), 1u);
  EXPECT_EQ(finished_runs(out).count(sweep.runs[1].id), 1u);
  EXPECT_EQ(read_csv(out / "results.csv")[1][column(read_csv(out / "results.csv")[0], "status")], "missing");
  for (const auto& e : fs::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();

  const CommandResult rerun = dsnake("sweep " + file.string() + " --out " + out.string());
  EXPECT_EQ(rerun.exit_code, 0) << rerun.err;
  EXPECT_NE(rerun.err.find("2 runs, 1 finished already (skipped), running 1"), std::string::npos) << rerun.err;
  EXPECT_EQ(finished_runs(out).size(), 2u);
}

// A finished run is reused only while its result stands: an input image replaced after the
// runs, or a result made by another build, runs again and says why; --keep-stale keeps them and
// --aggregate-only aggregates them, never silently (a warning line, results.csv's "stale").
TEST_F(SweepTest, StaleResultsRunAgainAndSaySo) {
  auto write_square = [&](int half_width) {
    Image<2> im(Grid<2>{GridIndex<2>(64, 64), Point<2>(1, 1), Point<2>(0, 0)}, 0.0f);
    for (int64_t l = 0; l < im.num_voxels(); ++l) {
      const Point<2> x = im.grid().to_physical(im.grid().index(l)) - Point<2>(31.5, 31.5);
      im[l] = std::max(std::abs(x[0]), std::abs(x[1])) < half_width ? 200.0f : 50.0f;
    }
    write_image<2>(im, (dir_ / "square.nii.gz").string());
  };
  write_square(16);
  json exp = tiny_experiment();
  exp["image"] = {{"file", "square.nii.gz"}};
  write("exp.json", exp.dump(2));
  const fs::path file = write("sweep.json", R"({"base": "exp.json", "seeds": [0, 1]})"), out = dir_ / "out";
  const std::string sweep = "sweep " + file.string() + " --out " + out.string();
  ASSERT_EQ(dsnake(sweep).exit_code, 0);
  const Sweep loaded = load_sweep(file.string(), false);
  const fs::path result0 = out / "runs" / loaded.runs[0].id / "result.json";
  const json recorded = json::parse(slurp(result0));
  EXPECT_EQ(recorded["provenance"]["inputs"]["image.file"]["path"], (dir_ / "square.nii.gz").string());
  EXPECT_EQ(recorded["provenance"]["inputs"]["image.file"]["sha256"].get<std::string>().size(), 64u);
  EXPECT_EQ(recorded["provenance"]["build"]["version"], recorded["version"]);

  // Unchanged: both skipped.
  CommandResult again = dsnake(sweep);
  EXPECT_NE(again.err.find("2 runs: 2 skipped, 0 finished, 0 process failed"), std::string::npos) << again.err;

  // The image replaced: both run again, each saying why.
  write_square(15);
  again = dsnake(sweep);
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.err.find("running again " + loaded.runs[0].label() + ": its input image.file (" +
                           (dir_ / "square.nii.gz").string() + ") changed since it ran"),
            std::string::npos) << again.err;
  EXPECT_NE(again.err.find("2 runs: 0 skipped, 2 finished (2 of them again: stale)"), std::string::npos) << again.err;
  EXPECT_NE(json::parse(slurp(result0))["provenance"]["inputs"]["image.file"]["sha256"],
            recorded["provenance"]["inputs"]["image.file"]["sha256"]);

  // A result from another build: --aggregate-only and --keep-stale aggregate it with a warning and
  // its reason in results.csv; a plain rerun runs it again.
  json foreign = json::parse(slurp(result0));
  foreign["provenance"]["build"]["version"] = "0.0.1+foreign";
  std::ofstream(result0) << foreign.dump(2);
  const std::string reason = "another build made it (version 0.0.1+foreign; this is " + recorded["version"].get<std::string>() + ")";
  for (const std::string flag : {" --aggregate-only", " --keep-stale"}) {
    SCOPED_TRACE(flag);
    again = dsnake(sweep + flag);
    EXPECT_EQ(again.exit_code, 0) << again.err;
    EXPECT_NE(again.err.find("warning: 1 of the 2 finished results no longer stand"), std::string::npos) << again.err;
    const auto rows = read_csv(out / "results.csv");
    EXPECT_EQ(rows[1][column(rows[0], "stale")], reason);
    EXPECT_EQ(rows[1][column(rows[0], "build")], "0.0.1+foreign");
    EXPECT_EQ(rows[2][column(rows[0], "stale")], "");
    EXPECT_EQ(json::parse(slurp(result0))["provenance"]["build"]["version"], "0.0.1+foreign");  // kept
  }
  again = dsnake(sweep);
  EXPECT_NE(again.err.find("running again " + loaded.runs[0].label() + ": " + reason), std::string::npos) << again.err;
  EXPECT_NE(again.err.find("2 runs: 1 skipped, 1 finished (1 of them again: stale)"), std::string::npos) << again.err;
  EXPECT_EQ(json::parse(slurp(result0))["provenance"]["build"]["version"], recorded["version"]);
  EXPECT_EQ(again.err.find("no longer stand"), std::string::npos) << again.err;  // no stale result left
}

// --manifest parallel writes one command per unfinished run for GNU parallel; after it, an
// --aggregate-only pass builds the table. --manifest slurm: a job array over the same lines.
TEST_F(SweepTest, ManifestRunsUnderGnuParallelAndSlurm) {
  ASSERT_EQ(shell("parallel --version").exit_code, 0) << "GNU parallel is missing (apt-get install parallel)";
  const fs::path file = write("sweep.json", R"({"base": "exp.json",
    "corruptions": [[], [{"type": "noise", "sigma": 20}]], "seeds": [3, 4]})");
  const fs::path out = dir_ / "out";
  const CommandResult manifest = dsnake("sweep " + file.string() + " --out " + out.string() + " --manifest parallel");
  ASSERT_EQ(manifest.exit_code, 0) << manifest.err;
  const Sweep sweep = load_sweep(file.string(), false);
  const std::string lines = slurp(out / "manifest.txt");
  // The executable: $DSNAKE, by default the writer's; paths relative to the sweep's folder.
  EXPECT_EQ(count_lines(lines, "\"${DSNAKE:-" + fs::canonical(DSNAKE_EXE).string() + "}\" run configs/"), 4) << lines;
  for (const auto& run : sweep.runs) {
    EXPECT_EQ(count_lines(lines, "--out runs/" + run.id + " --threads 1 --quiet"), 1) << lines;
    EXPECT_TRUE(fs::exists(out / "configs" / (run.id + ".json")));
  }
  EXPECT_TRUE(finished_runs(out).empty()) << "--manifest ran something";

  // Run from the folder moved elsewhere, with the executable named by $DSNAKE.
  const fs::path moved = dir_ / "moved";
  fs::rename(out, moved);
  const CommandResult par = shell("cd " + moved.string() + " && DSNAKE=" + std::string(DSNAKE_EXE) +
                                  " parallel --will-cite -j 2 < manifest.txt");
  fs::rename(moved, out);
  ASSERT_EQ(par.exit_code, 0) << par.err;
  EXPECT_EQ(finished_runs(out).size(), 4u);
  ASSERT_EQ(dsnake("sweep " + file.string() + " --out " + out.string() + " --aggregate-only").exit_code, 0);
  const auto rows = read_csv(out / "results.csv");
  ASSERT_EQ(rows.size(), 5u);
  for (size_t i = 1; i < rows.size(); ++i) EXPECT_NE(rows[i][column(rows[0], "status")], "missing");

  // Slurm: two runs unfinished. Measured from the two finished (runs of milliseconds): both
  // lines in one task of at least 10 minutes and 1 GB; given on the command line: one line per
  // task, two tasks, at most one at once. Each task runs its lines in the submit folder.
  const std::string third = sweep.runs[2].id, last = sweep.runs[3].id;
  fs::remove_all(out / "runs" / third);
  fs::remove_all(out / "runs" / last);
  ASSERT_EQ(dsnake("sweep " + file.string() + " --out " + out.string() + " --manifest slurm").exit_code, 0);
  EXPECT_EQ(count_lines(slurp(out / "manifest.txt"), " run "), 2);
  std::string script = slurp(out / "sweep.slurm");
  for (const char* line : {"#SBATCH --array=0-0\n", "#SBATCH --time=10\n", "#SBATCH --mem=1024M\n",
                           "#SBATCH --cpus-per-task=1\n", "#SBATCH --output=logs/slurm-%A_%a.log\n",
                           "from 2 finished runs"})
    EXPECT_NE(script.find(line), std::string::npos) << line << "\n" << script;
  ASSERT_EQ(dsnake("sweep " + file.string() + " --out " + out.string() +
                   " --manifest slurm --slurm-lines-per-task 1 --slurm-max-running 1 --slurm-time 30 --slurm-mem 2000")
                .exit_code,
            0);
  script = slurp(out / "sweep.slurm");
  for (const char* line : {"#SBATCH --array=0-1%1\n", "#SBATCH --time=30\n", "#SBATCH --mem=2000M\n"})
    EXPECT_NE(script.find(line), std::string::npos) << line << "\n" << script;
  for (int task : {1, 0}) {
    const CommandResult run = shell("cd / && SLURM_ARRAY_TASK_ID=" + std::to_string(task) + " SLURM_SUBMIT_DIR=" +
                                    out.string() + " bash " + (out / "sweep.slurm").string());
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_TRUE(fs::exists(out / "runs" / (task == 0 ? third : last) / "result.json")) << task;
  }
}

TEST_F(SweepTest, CommandOnABadSweepFileIsOneLineAndExitCode2) {
  const fs::path file = write("sweep.json", R"({"base": "exp.json", "grid": {"energies[0].alpha": [0.1, "x"]}})");
  const fs::path out = dir_ / "out";
  const CommandResult r = dsnake("sweep " + file.string() + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(file.string()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("energies[0].alpha"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  const CommandResult missing = dsnake("sweep " + (dir_ / "none.json").string() + " --out " + out.string());
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("none.json: no such sweep file"), std::string::npos) << missing.err;
}

}  // namespace
}  // namespace dsnake
