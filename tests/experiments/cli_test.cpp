// The dsnake command on bad input: exactly one line on stderr naming the file and the JSON
// path or element, exit code 2, and nothing in the output folder.
#include "experiments/builtin.h"
#include "framework/io/image_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

class CliTest : public test_support::TempDirTest {
 protected:

  CommandResult dsnake(const std::string& args) {
    const std::string out = (dir_ / "stdout.txt").string(), err = (dir_ / "stderr.txt").string();
    const std::string cmd = std::string(DSNAKE_EXE) + " " + args + " >" + out + " 2>" + err;
    const int status = std::system(cmd.c_str());
    CommandResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
  }
  fs::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
  // A small version of a built-in experiment, modified by `edit`, written to exp.json.
  fs::path experiment(const std::string& builtin, const std::function<void(nlohmann::json&)>& edit) {
    auto j = nlohmann::json::parse(builtin_experiment_text(builtin));
    for (auto& p : j["phases"]) p["iterations"] = 2;
    edit(j);
    return write("exp.json", j.dump(2));
  }
  // Runs `dsnake run FILE --out DIR/out` and checks the bad-input contract.
  void expect_bad_input(const fs::path& file, const std::vector<std::string>& fragments) {
    const fs::path out = dir_ / "out";
    const CommandResult r = dsnake("run " + file.string() + " --out " + out.string());
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const auto& f : fragments) EXPECT_NE(r.err.find(f), std::string::npos) << "missing \"" << f << "\" in: " << r.err;
    EXPECT_FALSE(fs::exists(out)) << "the output folder was created";
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();
  }
  static std::string icosahedron_off(bool drop_face) {
    std::string s = "OFF\n12 " + std::to_string(drop_face ? 19 : 20) + " 0\n";
    const double g = 1.618033988749895;
    const double v[12][3] = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                             {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    const int f[20][3] = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                          {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                          {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    for (auto& p : v) s += std::to_string(31.5 + 20 * p[0]) + " " + std::to_string(31.5 + 20 * p[1]) + " " +
                           std::to_string(31.5 + 20 * p[2]) + "\n";
    for (int k = 0; k < (drop_face ? 19 : 20); ++k)
      s += "3 " + std::to_string(f[k][0]) + " " + std::to_string(f[k][1]) + " " + std::to_string(f[k][2]) + "\n";
    return s;
  }
};

TEST_F(CliTest, HelpOnEveryCommand) {
  for (const std::string args : {"--help", "run --help", "validate --help"}) {
    const CommandResult r = dsnake(args);
    EXPECT_EQ(r.exit_code, 0) << args;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << args;
  }
}

TEST_F(CliTest, ValidateAcceptsTheBuiltinsAndAGoodFile) {
  EXPECT_EQ(dsnake("validate builtin:default").exit_code, 0);
  EXPECT_EQ(dsnake("validate builtin:ellipsoid").exit_code, 0);
  const auto file = experiment("default", [](nlohmann::json&) {});
  const CommandResult r = dsnake("validate " + file.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("valid 2D experiment"), std::string::npos);
}

TEST_F(CliTest, ValidateChecksEveryRunOfASweepFile) {
  const auto good = write("sweep.json", R"({"base": "builtin:default", "grid": {"energies[0].alpha": [0.1, 0.2]},
                                          "seeds": [0, 1, 2]})");
  const CommandResult r = dsnake("validate " + good.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("valid sweep of 6 runs"), std::string::npos) << r.out;
  const auto bad = write("bad_sweep.json", R"({"base": "builtin:default", "grid": {"energies[0].alpha": [0.1, -1]}})");
  const CommandResult b = dsnake("validate " + bad.string());
  EXPECT_EQ(b.exit_code, 2);
  EXPECT_EQ(std::count(b.err.begin(), b.err.end(), '\n'), 1) << b.err;
  EXPECT_NE(b.err.find("alpha"), std::string::npos) << b.err;
}

TEST_F(CliTest, ConfigSyntaxError) {
  const auto file = write("exp.json", "{\n  \"dimension\": 2,\n  \"seed\": 1,,\n}\n");
  expect_bad_input(file, {file.string(), "JSON syntax error", "line 3"});
}

TEST_F(CliTest, ConfigUnknownKey) {
  const auto file = experiment("default", [](nlohmann::json& j) { j["energies"][0]["alhpa"] = 0.1; });
  expect_bad_input(file, {file.string(), "energies[0].alhpa", "unknown key"});
}

TEST_F(CliTest, ConfigUnknownType) {
  const auto file = experiment("default", [](nlohmann::json& j) { j["field"]["type"] = "gvff"; });
  expect_bad_input(file, {file.string(), "field.type", "gvff"});
}

TEST_F(CliTest, ConfigWrongType) {
  const auto file = experiment("default", [](nlohmann::json& j) { j["energies"][1]["tau"] = "fast"; });
  expect_bad_input(file, {file.string(), "energies[1].tau", "expected a number"});
}

TEST_F(CliTest, ConfigOutOfRangeValue) {
  const auto file = experiment("default", [](nlohmann::json& j) { j["phases"][0]["iterations"] = -5; });
  expect_bad_input(file, {file.string(), "phases[0].iterations", "must be"});
}

TEST_F(CliTest, SetOverrideIsValidatedToo) {
  const auto file = experiment("default", [](nlohmann::json&) {});
  const fs::path out = dir_ / "out";
  // --set before the file: each --set takes one value, the file stays the positional argument.
  const CommandResult r = dsnake("run --set seed=3 --set energies[0].alpha=-1 " + file.string() + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("energies[0].alpha"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(CliTest, MissingImage) {
  const auto file = experiment("default", [](nlohmann::json& j) { j["image"] = {{"file", "no_such_image.mha"}}; });
  expect_bad_input(file, {"no_such_image.mha"});
}

TEST_F(CliTest, TruncatedImage) {
  write("truncated.mha",
        "ObjectType = Image\nNDims = 2\nDimSize = 64 64\nElementSpacing = 1 1\nElementType = MET_FLOAT\n"
        "ElementDataFile = LOCAL\n" + std::string(100, '\0'));
  const auto file = experiment("default", [](nlohmann::json& j) { j["image"] = {{"file", "truncated.mha"}}; });
  expect_bad_input(file, {"truncated.mha"});
}

TEST_F(CliTest, ImageOfTheWrongDimension) {
  Grid<2> g;
  g.size = {16, 16};
  write_image(Image<2>(g, 1.0f), (dir_ / "flat.mha").string());
  const auto file = experiment("ellipsoid", [](nlohmann::json& j) { j["image"] = {{"file", "flat.mha"}}; });
  expect_bad_input(file, {"flat.mha", "3D"});
}

TEST_F(CliTest, ImageWithNaN) {
  Grid<2> g;
  g.size = {16, 16};
  Image<2> img(g, 1.0f);
  img.at({3, 4}) = NAN;
  write_image(img, (dir_ / "nan.mha").string());
  const auto file = experiment("default", [](nlohmann::json& j) { j["image"] = {{"file", "nan.mha"}}; });
  expect_bad_input(file, {"nan.mha", "NaN"});
}

TEST_F(CliTest, OpenTemplateMesh) {
  write("open.off", icosahedron_off(true));
  const auto file = experiment("ellipsoid", [](nlohmann::json& j) { j["template"] = {{"file", "open.off"}}; });
  expect_bad_input(file, {"open.off", "not closed"});
}

TEST_F(CliTest, NonManifoldTemplateMesh) {
  write("nonmanifold.off",
        "OFF\n7 8 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n-1 0 0\n0 -1 0\n0 0 -1\n"
        "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 0 5 4\n3 0 4 6\n3 0 6 5\n3 4 5 6\n");
  const auto file = experiment("ellipsoid", [](nlohmann::json& j) { j["template"] = {{"file", "nonmanifold.off"}}; });
  expect_bad_input(file, {"nonmanifold.off", "non-manifold"});
}

TEST_F(CliTest, EmptyTemplate) {
  write("empty.txt", "# no vertices\n");
  const auto file = experiment("default", [](nlohmann::json& j) { j["template"] = {{"file", "empty.txt"}}; });
  expect_bad_input(file, {"empty.txt"});
  write("empty.off", "OFF\n0 0 0\n");
  const auto file3 = experiment("ellipsoid", [](nlohmann::json& j) { j["template"] = {{"file", "empty.off"}}; });
  expect_bad_input(file3, {"empty.off", "empty"});
}

TEST_F(CliTest, UnknownCommandLineOptionIsBadInput) {
  const CommandResult r = dsnake("run --frobnicate");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace
}  // namespace dsnake
