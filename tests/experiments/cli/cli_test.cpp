// The dsnake command on bad input: exactly one line on stderr naming the file and the JSON
// path or element, exit code 2, and nothing in the output folder.
#include "experiments/spec/builtin.h"
#include "experiments/output/output_folder.h"
#include "framework/io/image_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <sys/stat.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

class CliTest : public test_support::TempDirTest {
 protected:

  CommandResult dsnake(const std::string& args) { return dsnake_with_environment("", args); }
  // `environment` (NAME=value ...) is set for the command only.
  CommandResult dsnake_with_environment(const std::string& environment, const std::string& args) {
    const std::string out = (dir_ / "stdout.txt").string(), err = (dir_ / "stderr.txt").string();
    const std::string cmd = (environment.empty() ? "" : "env " + environment + " ") + std::string(DSNAKE_EXE) + " " +
                            args + " >" + out + " 2>" + err;
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

// OpenCV's image codecs (and the 140 libraries they bring: 40 MB of resident memory in every
// process) are not linked: dsnake opens them when it first reads or writes a raster file
// (framework/io/raster_codecs.h). The PNG round trips of the field command and the
// figures tests run through that path.
TEST_F(CliTest, TheImageCodecsAreNotLinked) {
  const CommandResult r = [&] {
    const std::string out = (dir_ / "needed.txt").string();
    CommandResult c;
    c.exit_code = WEXITSTATUS(std::system(("readelf -d " + std::string(DSNAKE_EXE) + " >" + out).c_str()));
    c.out = slurp(out);
    return c;
  }();
  ASSERT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("libopencv_core"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("libopencv_imgcodecs"), std::string::npos) << r.out;
}

// A run that writes its PNG figures does not open the image codecs either: PNG files are written
// with libpng (framework/io/raster_codecs.h; opening the codecs takes about 90 ms).
// The dynamic loader's log (LD_DEBUG=files) names every library the process opens.
TEST_F(CliTest, WritingTheFiguresDoesNotOpenTheImageCodecs) {
  const fs::path out = dir_ / "out";
  const CommandResult r = dsnake_with_environment(
      "LD_DEBUG=files", "run --quiet --set phases.0.iterations=3 --set phases.1.iterations=3 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err.substr(0, 2000);
  EXPECT_TRUE(fs::is_regular_file(out / "overlay.png"));
  EXPECT_GT(fs::file_size(out / "overlay.png"), 1000u);
  EXPECT_NE(r.err.find("libopencv_core"), std::string::npos) << "no loader log";
  EXPECT_EQ(r.err.find("libopencv_imgcodecs"), std::string::npos);
}

// The version names the commit the binary was built from (written at build time, not when
// CMake configured): "<project version>+<git describe --always --dirty>" in a git checkout,
// with "-dirty" exactly when tracked files differ from that commit.
TEST_F(CliTest, TheVersionNamesTheCommitItWasBuiltFrom) {
  const CommandResult v = dsnake("--version");
  ASSERT_EQ(v.exit_code, 0);
  const std::string version = v.out.substr(0, v.out.find('\n'));
  const std::string git = "git -C " + std::string(DSNAKE_SOURCE_DIR);
  const std::string head_file = (dir_ / "head.txt").string(), status_file = (dir_ / "status.txt").string();
  const bool checkout = std::system((git + " rev-parse HEAD >" + head_file + " 2>/dev/null").c_str()) == 0;
  if (!checkout) {  // sources without git: the project version alone
    EXPECT_EQ(version.find('+'), std::string::npos) << version;
    return;
  }
  ASSERT_EQ(std::system((git + " status --porcelain --untracked-files=no >" + status_file).c_str()), 0);
  const std::string head = slurp(head_file).substr(0, 40);
  const bool dirty = !slurp(status_file).empty();
  const size_t plus = version.find('+');
  ASSERT_NE(plus, std::string::npos) << version;
  std::string described = version.substr(plus + 1);
  const std::string suffix = "-dirty";
  const bool says_dirty = described.size() > suffix.size() && described.ends_with(suffix);
  EXPECT_EQ(says_dirty, dirty) << version;
  if (says_dirty) described.resize(described.size() - suffix.size());
  // "<hash>", or "<tag>-<n>-g<hash>" after a tag.
  const size_t g = described.rfind("-g");
  const std::string hash = g == std::string::npos ? described : described.substr(g + 2);
  ASSERT_GE(hash.size(), 7u) << version;
  EXPECT_EQ(head.substr(0, hash.size()), hash) << version << " built from another commit than HEAD " << head;
}

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

// image.nifti_transform and --nifti-transform: a bad value is one line naming the file and the
// key or option, exit code 2, nothing written.
TEST_F(CliTest, BadNiftiTransformKeyAndOption) {
  const auto file = experiment("default", [](nlohmann::json& j) { j["image"]["nifti_transform"] = "sfrom"; });
  expect_bad_input(file, {file.string() + ": image.nifti_transform: must be \"auto\", \"sform\" or \"qform\"", "sfrom"});
  const auto typed = experiment("default", [](nlohmann::json& j) { j["image"]["nifti_transform"] = 2; });
  expect_bad_input(typed, {typed.string() + ": image.nifti_transform"});

  Grid<3> g;
  g.size = {64, 64, 64};  // the icosahedron's size (31.5 +- 32 mm): `init` refuses a template far outside
  Image<3> labels(g, 0.0f);
  labels.at({3, 3, 3}) = 1;
  const std::string nii = (dir_ / "labels.nii.gz").string();
  write_image(labels, nii, ImageWriteOptions{.label = true});
  write("t.off", icosahedron_off(false));
  const std::string out = (dir_ / "written").string();
  const std::string cases[] = {
      "template --mask " + nii + " --label 1 --out " + out + ".off --nifti-transform both",
      "convert " + nii + " " + out + ".mha --nifti-transform both",
      "field --image " + nii + " --out " + out + ".mha --nifti-transform both",
      "init --image " + nii + " --template " + (dir_ / "t.off").string() + " --nifti-transform both"};
  for (const std::string& args : cases) {
    const CommandResult r = dsnake(args);
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_EQ(r.err, "dsnake: error: " + nii + ": --nifti-transform both: must be \"auto\", \"sform\" or \"qform\"\n") << args;
    EXPECT_EQ(r.out, "") << args;
    for (const char* ext : {".off", ".mha", ".png"}) EXPECT_FALSE(fs::exists(out + ext)) << args;
  }
  // A good value is accepted, and `init` writes it into the experiment file.
  const CommandResult ok = dsnake("init --image " + nii + " --template " + (dir_ / "t.off").string() + " --nifti-transform qform");
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(nlohmann::json::parse(ok.out)["image"]["nifti_transform"], "qform");
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

// Hostile input files and --set paths: each is one line naming the file or the --set
// path, exit code 2, and no output folder. Rows: the arguments after "run", what the line says.
TEST_F(CliTest, HostileFilesAndSetPathsAreOneLineAndExitTwo) {
  std::string deep;
  for (int k = 0; k < 100000; ++k) deep += "{\"a\":";
  deep += "1";
  deep += std::string(100000, '}');
  const fs::path deep_file = write("deep.json", deep);
  const fs::path deep_array = write("deep_array.json", std::string(5000, '[') + std::string(5000, ']'));
  fs::create_directories(dir_ / "folder.json");
  const fs::path fifo = dir_ / "fifo.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string huge(100000, 'x');  // one shell argument holds at most 128 kB
  const fs::path huge_key = experiment("default", [](nlohmann::json& j) { j[std::string(1 << 20, 'k')] = 1; });
  // a figure-eight contour as the template
  auto eight = nlohmann::json::parse(builtin_experiment_text("default"));
  eight["template"] = {{"file", write("eight.txt", "40 40\n80 80\n80 40\n40 80\n").string()}};
  const fs::path eight_experiment = write("eight.json", eight.dump());
  // a field check that needs the image (a VFC radius larger than it) names the experiment file
  auto vfc = nlohmann::json::parse(builtin_experiment_text("default"));
  vfc["field"] = {{"type", "vfc"}, {"radius", 10}};
  const fs::path vfc_experiment = write("vfc.json", vfc.dump());
  const fs::path fifo_mesh = dir_ / "pipe.off", folder_image = dir_ / "folder.png";
  ASSERT_EQ(::mkfifo(fifo_mesh.c_str(), 0600), 0);
  fs::create_directories(folder_image);
  const std::vector<std::pair<std::string, std::string>> rows = {
      {"builtin:ellipsoid --set 'template={\"file\": \"" + fifo_mesh.string() + "\"}'", "pipe.off: expected the mesh or contour file, found a pipe"},
      {"builtin:default --set 'image={\"file\": \"" + folder_image.string() + "\"}'", "folder.png: expected the image file, found a folder"},
      {deep_file.string(), "nested deeper than 64"},
      // found by fuzzing: a number past double's range, and --set text that is not UTF-8
      {write("overflow.json", "{\"dimension\": 2, \"seed\": 1e999}").string(), "overflow.json: JSON number out of range"},
      {"builtin:default --set \"$(printf 'name=caf\\351')\"", "is not valid UTF-8"},
      {deep_array.string(), "nested deeper than 64"},
      {(dir_ / "folder.json").string(), "found a folder"},
      {fifo.string(), "found a pipe"},
      {"builtin:default --set 'energies[x].alpha=1'", "--set energies[x].alpha"},
      {"builtin:default --set 'energies[99999999999999999999].alpha=1'", "is not an index"},
      {"builtin:default --set 'energies[].alpha=1'", "is not an index"},
      {"builtin:default --set 'energies[0.5].alpha=7'", "\"[0.5]\" is not an index"},
      {"builtin:default --set 'energies[0x1].alpha=7'", "\"[0x1]\" is not an index"},
      {"builtin:default --set 'energies[-1].alpha=7'", "is not an index"},
      {"builtin:default --set 'energies[0]..alpha=7'", "an empty key"},
      {"builtin:default --set '.name=x'", "an empty key"},
      {"builtin:default --set 'name.=x'", "an empty key"},
      {"builtin:default --set 'energies]0[.alpha=1'", "without '['"},
      {"builtin:default --set 'energies[0.alpha=1'", "unclosed '['"},
      {"builtin:default --set 'energies[0].alpha=" + std::string(70, '[') + std::string(70, ']') + "'", "nested deeper than 64"},
      {"builtin:default --set 'energies[0].alpha=\"" + huge + "\"'", "expected a number"},
      {huge_key.string(), "characters)"},
      {"builtin:ellipsoid --set template.transform.scale=1e200", "template.transform"},
      {eight_experiment.string(), "crosses itself"},
      {vfc_experiment.string() + " --set field.radius=5000", "vfc.json: field.radius: VFC radius"},
      {write("empty.json", "").string(), "empty.json: JSON syntax error"},
      {write("binary.json", std::string("\x01\x02\x1b[31m\x7f\n\xff", 9)).string(), "binary.json: JSON syntax error"},
      {write("array.json", "[1, 2]").string(), "expected a JSON object"},
      {write("dim4.json", "{\"dimension\": 4}").string(), "dimension: must be 2 or 3"},
      {write("unclosed.json", "{\"dimension\": 2, \"image\": {\"phantom\": \"disk\"}").string(), "unclosed.json: JSON syntax error"},
      {"builtin:default --set x", "expected key.path=value"},
      {"builtin:default --set =1", "expected key.path=value"},
      {"builtin:default --set 'phases[0].iterations=-5'", "phases[0].iterations: must be in"},
      {"builtin:default --set 'phases[0].iterations=1e12'", "phases[0].iterations: expected an integer"},
      {"builtin:default --set 'energies=[]'", "energies: expected a non-empty array"},
      {"builtin:default --set name.first=1", "not an object"},
      {"builtin:default --set 'phases[0]=7'", "phases[0]: expected a JSON object"},
      {"builtin:default --set 'energies[0].weight=NaN'", "energies[0].weight: expected a number"},
      {"builtin:default --set image.phantom=nosuch", "unknown 2D image phantom"},
      // a phantom's keys are its family's declared options: an unknown one, one out of range
      {"builtin:default --set image.radiuss=3", "default: image.radiuss: unknown key"},
      {"builtin:default --set template.vertices=2", "default: template.vertices: must be in [3, 100000]"},
      {"builtin:ellipsoid --set 'image.spacing=[1, -1, 1]'", "ellipsoid: image.spacing: must be > 0"},
      {"builtin:default --set watchdog.max_move=-1", "watchdog.max_move"},
      {"builtin:default --set watchdog.bogus=1", "watchdog.bogus: unknown key"},
      {"builtin:default --set 'template.transform.translation=[1e300, 0]'", "outside the image"},
      // a ground truth far from the image: a phantom's object, a surface file, a target
      {"builtin:classical --set image.half_width=1e300", "classical: image: the phantom's object (its true surface) lies outside"},
      {"builtin:default --set 'ground_truth={\"surface\": \"" +
           write("far.txt", "1e9 0\n1e9 10\n-5 10\n").string() + "\"}'",
       "far.txt: vertex 0: the ground-truth surface lies outside the image"},
      {"builtin:default --set success.hausdorff95=-1", "success.hausdorff95: must be >= 0"},
      {"builtin:ellipsoid --set template.radius=1e-12", "template.transform: the placed template spans 3.46e-12 mm, less than a voxel"},
      // an explicit GVF step that no image makes stable, refused at assembly (before the image's field)
      {"builtin:default --set 'field={\"type\": \"gvf\", \"solver\": \"explicit\", \"time_step\": 100}'",
       "default: field.time_step: explicit GVF step"},
      {"builtin:ellipsoid --set 'field={\"type\": \"ddgvf\", \"solver\": \"explicit\", \"time_step\": 5}'",
       "field.time_step: explicit GVF step"},
  };
  const fs::path out = dir_ / "out";
  for (const auto& [args, fragment] : rows) {
    const CommandResult r = dsnake("run " + args + " --out " + out.string());
    const std::string row = args.substr(0, 80);
    EXPECT_EQ(r.exit_code, 2) << row << ": " << r.err.substr(0, 300);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << row << ": " << r.err.substr(0, 300);
    EXPECT_NE(r.err.find(fragment), std::string::npos) << row << ": missing \"" << fragment << "\" in " << r.err.substr(0, 300);
    EXPECT_LT(r.err.size(), 1000u) << row;
    EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << row << ": a terminal control code in the line";
    EXPECT_FALSE(fs::exists(out)) << row;
  }
  // validate on a pipe answers at once too
  const CommandResult v = dsnake("validate " + fifo.string());
  EXPECT_EQ(v.exit_code, 2);
  EXPECT_NE(v.err.find("found a pipe"), std::string::npos) << v.err;
}

// A full disk (no output may look complete): simulated by a file size limit
// (ulimit -f, with SIGXFSZ ignored, so a write fails as it does with ENOSPC). The command exits 1
// with one line naming the output and the system's reason, and leaves no file, temporary or not.
TEST_F(CliTest, AFullDiskLeavesNoOutputAndOneLine) {
  Grid<3> g;
  g.size = GridIndex<3>(48, 48, 48);
  Image<3> img(g, 0.0f);
  for (int64_t i = 0; i < g.num_voxels(); ++i) img.data()[size_t(i)] = float((i * 7919) % 101);
  write_image(img, (dir_ / "img.mha").string());
  auto limited = [&](const std::string& args, int kilobytes) {
    const std::string cmd = "trap '' XFSZ; ulimit -f " + std::to_string(kilobytes) + "; " + std::string(DSNAKE_EXE) +
                            " " + args + " >" + (dir_ / "stdout.txt").string() + " 2>" + (dir_ / "stderr.txt").string();
    const int status = std::system(("sh -c \"" + cmd + "\"").c_str());
    return std::make_pair(WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp((dir_ / "stderr.txt").string()));
  };
  const auto [code, err] = limited("field --image " + (dir_ / "img.mha").string() + " --type gradient --out " +
                                       (dir_ / "f.mha").string(), 300);
  EXPECT_EQ(code, 1) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("dsnake: error: " + (dir_ / "f.mha").string() + ": cannot write (File too large)"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "f.mha"));
  // A gzip stream that fails part-way (it goes to its file a megabyte at a time as it is made:
  // noise of 2 MB hardly compresses): the same.
  g.size = GridIndex<3>(80, 80, 80);
  Image<3> noise(g, 0.0f);
  uint32_t state = 12345;
  for (float& v : noise.data()) v = float((state = state * 1664525u + 1013904223u) >> 8);
  write_image(noise, (dir_ / "noise.mha").string());
  for (const std::string out : {"g.nii.gz", "g.nrrd"}) {
    const auto [gz_code, gz_err] =
        limited("convert " + (dir_ / "noise.mha").string() + " " + (dir_ / out).string(), 1500);
    EXPECT_EQ(gz_code, 1) << gz_err;
    EXPECT_EQ(std::count(gz_err.begin(), gz_err.end(), '\n'), 1) << gz_err;
    EXPECT_NE(gz_err.find((dir_ / out).string() + ": cannot write (File too large)"), std::string::npos) << gz_err;
    EXPECT_FALSE(fs::exists(dir_ / out));
  }
  // A run: result.json and the figures fail to fit; no output folder, no staging folder.
  const auto [run_code, run_err] = limited("run builtin:default -q --out " + (dir_ / "out").string(), 2);
  EXPECT_EQ(run_code, 1) << run_err;
  EXPECT_NE(run_err.find("cannot write (File too large)"), std::string::npos) << run_err;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  for (const auto& e : fs::directory_iterator(dir_)) {
    const std::string name = e.path().filename().string();
    EXPECT_EQ(name.find(".tmp-"), std::string::npos) << name;
    EXPECT_EQ(name.find(".partial-"), std::string::npos) << name;
  }
}

// The numeric watchdog: a run whose forces send the snake to infinity stops as
// diverged with exit code 3, writes the last finite state and its metrics, names the term, and
// leaves no staging folder; the watchdog's bound and vertex cap are keys.
// The report step after a run: the matplotlib figures and report.html beside the run's own
// outputs; without a python3 that can run the report script, one warning line, exit 0 and the
// run's outputs all there; a rerun into the folder without a report removes the old one.
TEST_F(CliTest, RunWritesItsReportAndWithoutPythonWarnsInOneLine) {
  const fs::path file = experiment("default", [](nlohmann::json&) {});
  const fs::path out = dir_ / "out";
  CommandResult r = dsnake("run " + file.string() + " --out " + out.string() + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  for (const char* f : {"report.html", "energy.png", "convergence.png", "overlay.png", "result.json"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_NE(slurp(out / "report.html").find("DsnakeViewer"), std::string::npos);  // the 3D view's bundle is inlined

  r = dsnake_with_environment("DSNAKE_PYTHON=/nonexistent/python3",
                              "run " + file.string() + " --out " + out.string() + " --quiet");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find("warning: the report of " + out.string()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("/nonexistent/python3 could not run"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(out / "result.json"));
  EXPECT_TRUE(fs::exists(out / "overlay.png"));
  for (const char* f : {"report.html", "energy.png", "convergence.png"})
    EXPECT_FALSE(fs::exists(out / f)) << f << ": the earlier run's report is gone";

  r = dsnake("report " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "report.html"));
  r = dsnake("report " + (dir_ / "nowhere").string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST_F(CliTest, ADivergingRunStopsWithExitCodeThreeAndFiniteOutputs) {
  const fs::path out = dir_ / "out";
  const CommandResult r = dsnake("run builtin:default --set 'energies[1].tau=1e308' --out " + out.string());
  EXPECT_EQ(r.exit_code, 3) << r.err;
  const auto result = nlohmann::json::parse(slurp((out / "result.json").string()));
  EXPECT_EQ(result["status"], "diverged");
  EXPECT_EQ(result["success"], false);
  EXPECT_EQ(result["divergence"]["term"], "energies[1] (external)");
  EXPECT_EQ(result["divergence"]["phase_iteration"], 1);
  EXPECT_TRUE(result["metrics"]["dice"].is_number());
  const std::string final_txt = slurp((out / "final.txt").string());
  EXPECT_EQ(final_txt.find("inf"), std::string::npos);
  EXPECT_EQ(final_txt.find("nan"), std::string::npos);
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();
  // A bound of 0.01 mm per iteration stops the ordinary run at its first iteration.
  const CommandResult bounded = dsnake("run builtin:default --set watchdog.max_move=0.01 --quiet --out " + out.string());
  EXPECT_EQ(bounded.exit_code, 3) << bounded.err;
  const auto b = nlohmann::json::parse(slurp((out / "result.json").string()));
  EXPECT_EQ(b["divergence"]["reason"], "a vertex moved more than watchdog.max_move in one iteration");
  EXPECT_GT(b["divergence"]["move"].get<double>(), 0.01);
  const CommandResult bad = dsnake("run builtin:default --set watchdog.max_vertices=2 --out " + (dir_ / "o2").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_NE(bad.err.find("watchdog.max_vertices"), std::string::npos) << bad.err;
}

// Output safety: dsnake writes only into a folder it owns and replaces only its own
// files. `run` of a 2-iteration built-in into `out`, with extra arguments.
class OutputFolderTest : public CliTest {
 protected:
  CommandResult run_into(const fs::path& out, const std::string& builtin, const std::string& extra = "") {
    const fs::path file = experiment(builtin, [](nlohmann::json& j) { j["output"]["figures"] = false; });
    return dsnake("run " + file.string() + " --quiet --out " + out.string() + " " + extra);
  }
  static void expect_refused(const CommandResult& r, const std::string& fragment) {
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("--out"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
  }
  // Every file under `dir` with its contents.
  static std::map<std::string, std::string> snapshot(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file()) files[e.path().lexically_relative(dir).string()] = slurp(e.path().string());
    return files;
  }
};

TEST_F(OutputFolderTest, TheRootAFileAndAFolderOfTheUsersAreRefused) {
  expect_refused(run_into("/", "default"), "root");
  const fs::path file = write("notes.txt", "mine\n");
  expect_refused(run_into(file, "default"), "a file, not a folder");
  EXPECT_EQ(slurp(file.string()), "mine\n");
  const fs::path thesis = dir_ / "thesis";
  fs::create_directories(thesis / "chapters");
  std::ofstream(thesis / "chapters" / "one.tex") << "text";
  std::ofstream(thesis / "result.json") << "{\"not\": \"ours\"}";  // not a dsnake result
  const auto before = snapshot(thesis);
  expect_refused(run_into(thesis, "default"), "--force");
  EXPECT_EQ(snapshot(thesis), before);
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();
  // --force writes dsnake's files beside the user's, which stay as they were
  const CommandResult forced = run_into(thesis, "default", "--force");
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_EQ(slurp((thesis / "chapters" / "one.tex").string()), "text");
  EXPECT_TRUE(fs::exists(thesis / "final.txt"));
  EXPECT_TRUE(fs::exists(thesis / kOutputManifest));
}

TEST_F(OutputFolderTest, ARunReplacesOnlyItsOwnFilesAndRemovesItsStaleOnes) {
  const fs::path out = dir_ / "out";
  ASSERT_EQ(run_into(out, "ellipsoid").exit_code, 0);
  ASSERT_TRUE(fs::exists(out / "final.ply"));
  // the user's files inside the output folder, one in a folder named like an output entry
  fs::create_directories(out / "snapshots");
  std::ofstream(out / "snapshots" / "thesis.tex") << "chapter 1";
  std::ofstream(out / "notes.md") << "my notes";
  // a 2D run into the former 3D folder: the 3D-only outputs go, the user's files stay
  const CommandResult r = run_into(out, "default", "--set output.snapshot_every=1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(out / "final.ply"));
  EXPECT_TRUE(fs::exists(out / "final.txt"));
  EXPECT_EQ(slurp((out / "snapshots" / "thesis.tex").string()), "chapter 1");
  EXPECT_EQ(slurp((out / "notes.md").string()), "my notes");
  EXPECT_FALSE(fs::is_empty(out / "snapshots"));
  const auto result = nlohmann::json::parse(slurp((out / "result.json").string()));
  EXPECT_EQ(result["config"]["dimension"], 2);
}

TEST_F(OutputFolderTest, AKilledRunsStagingFolderIsRemovedByTheNextRun) {
  const fs::path out = dir_ / "out";
  const fs::path stale = dir_ / "out.partial-999999999";  // no such process
  fs::create_directories(stale / "snapshots");
  std::ofstream(stale / "final.txt") << "half";
  const fs::path other = dir_ / "other.partial-999999999";  // another folder's: not ours to clean
  fs::create_directories(other);
  ASSERT_EQ(run_into(out, "default").exit_code, 0);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(other));
  EXPECT_TRUE(fs::exists(out / "result.json"));
}

TEST_F(OutputFolderTest, AnUnwritableParentIsOneLineNamingOut) {
  const fs::path blocker = write("blocker", "a file where a folder should be\n");
  expect_refused(run_into(blocker / "out", "default"), "out");
  EXPECT_EQ(slurp(blocker.string()), "a file where a folder should be\n");
}

}  // namespace
}  // namespace dsnake
