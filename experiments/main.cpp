// The dsnake command line: run or validate an experiment file (or a built-in experiment), or
// compute one external field.
//   dsnake run [CONFIG.json | builtin:NAME] [--out DIR] [--set key.path=value ...]
//              [--field-cache DIR] [--threads N] [--quiet]
//   dsnake validate CONFIG.json [--set ...]
//   dsnake field --image X --type gvf [--param key=value ...] [--field-cache DIR] --out field.mha
//   dsnake sweep SWEEP.json [--out DIR] [-j N] [--threads T] [--manifest parallel|slurm]
//                [--aggregate-only] [--quiet]                    (experiments/sweep.h)
// Exit codes: 0 done, 2 bad input (one line on stderr naming the file and the JSON path or
// element), 1 anything else (for a sweep: a run failed), 130 a sweep stopped by a signal.
#include "experiments/experiment.h"
#include "experiments/field_command.h"
#include "experiments/runner.h"
#include "experiments/sweep.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include "framework/errors.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <omp.h>

namespace {

using namespace dsnake;

ExperimentFile load(const std::string& config, const std::vector<std::string>& overrides) {
  if (config.empty()) return builtin_experiment("default", overrides);
  if (config.rfind("builtin:", 0) == 0) return builtin_experiment(config.substr(8), overrides);
  return load_experiment_file(config, overrides);
}

int run(const std::string& config, const std::vector<std::string>& overrides, const std::string& field_cache,
        const RunOptions& options) {
  ExperimentFile file = load(config, overrides);
  // --field-cache DIR is the field's "cache" key, for every run of a sweep alike.
  if (!field_cache.empty() && file.document.contains("field") && file.document["field"].is_object())
    file.document["field"]["cache"] = field_cache;
  if (file.dimension == 2) {
    auto ex = make_experiment<2>(file);
    run_experiment(ex, options);
  } else {
    auto ex = make_experiment<3>(file);
    run_experiment(ex, options);
  }
  return 0;
}

// Checks an experiment file, or a sweep file (one with "base"): every run it expands to is built.
int validate(const std::string& config, const std::vector<std::string>& overrides) {
  if (overrides.empty() && config.rfind("builtin:", 0) != 0) {
    std::ifstream in(config);
    const auto doc = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false, /*ignore_comments=*/true);
    if (doc.is_object() && doc.contains("base")) {
      const Sweep s = load_sweep(config, /*validate=*/true);
      std::printf("%s: valid sweep of %zu runs\n", config.c_str(), s.runs.size());
      return 0;
    }
  }
  const ExperimentFile file = load(config, overrides);
  if (file.dimension == 2) make_experiment<2>(file);
  else make_experiment<3>(file);
  std::printf("%s: valid %dD experiment\n", file.path.c_str(), file.dimension);
  return 0;
}

// Expands the sweep file and runs it (children: this executable), or writes its manifest, or
// only aggregates finished runs.
int sweep(const std::string& file, SweepOptions options) {
  const Sweep s = load_sweep(file, /*validate=*/!options.aggregate_only);
  if (options.out_dir.empty())  // DESIGN.md's `dsnake sweep FILE`: out/<the sweep file's name>
    options.out_dir = (std::filesystem::path("out") / std::filesystem::path(file).stem()).string();
  options.executable = std::filesystem::read_symlink("/proc/self/exe").string();
  const SweepSummary summary = run_sweep(s, options);
  if (summary.interrupted) return 130;
  return summary.failed > 0 ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dsnake: register a template shape to an image or a volume with snake forces "
               "(D-Snake, Levi & Gotsman)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", dsnake_version());

  std::string config;
  std::vector<std::string> overrides;
  RunOptions options;
  int threads = 0;
  auto* run_cmd = app.add_subcommand("run", "Run an experiment and write its output folder");
  run_cmd->add_option("config", config,
                      "Experiment file (JSON), or builtin:NAME (default, ellipsoid); none runs builtin:default");
  run_cmd->add_option("--out,-o", options.out_dir, "Output folder (default: out/<experiment name>)");
  run_cmd->add_option("--set", overrides, "Override a key of the experiment file: key.path=value (repeatable)")
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  run_cmd->add_option("--threads,-j", threads, "OpenMP threads (default: all cores)")->check(CLI::Range(1, 1024));
  run_cmd->add_flag("--quiet,-q", options.quiet, "No progress lines on stderr");
  std::string field_cache;
  run_cmd->add_option("--field-cache", field_cache, "Store and reuse computed fields in this folder");

  std::string validate_config;
  std::vector<std::string> validate_overrides;
  auto* validate_cmd = app.add_subcommand("validate", "Check an experiment or sweep file without running it");
  validate_cmd->add_option("config", validate_config, "Experiment file (JSON), sweep file, or builtin:NAME")->required();
  validate_cmd->add_option("--set", validate_overrides, "Override a key: key.path=value (repeatable)")
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);

  FieldCommandOptions field_options;
  auto* field_cmd =
      app.add_subcommand("field", "Compute one external field from an image and write it (2D: also a PNG)");
  field_cmd->add_option("--image", field_options.image, "Image or volume file")->required();
  field_cmd->add_option("--type", field_options.type, "gradient, gvf, ddgvf, vfc or distance (default gvf)");
  field_cmd->add_option("--param", field_options.params, "A field option key=value (repeatable), e.g. --param mu=0.1")
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  field_cmd->add_option("--field-cache", field_options.cache, "Field cache folder");
  field_cmd->add_option("--out,-o", field_options.out, "Output vector image (.mha, .mhd, .nii, .nii.gz)")->required();
  field_cmd->add_option("--png", field_options.png, "2D figure (default: --out with .png)");
  field_cmd->add_flag("--no-png", field_options.no_png, "No 2D figure");
  field_cmd->add_option("--threads,-j", threads, "OpenMP threads (default: all cores)")->check(CLI::Range(1, 1024));

  std::string sweep_file;
  SweepOptions sweep_options;
  auto* sweep_cmd = app.add_subcommand(
      "sweep", "Run an experiment over methods x parameter grid x corruption levels x seeds (resumable)");
  sweep_cmd->add_option("sweep", sweep_file, "Sweep file (JSON; format in experiments/sweep.h)")->required();
  sweep_cmd->add_option("--out,-o", sweep_options.out_dir,
                        "Output folder (runs/, results.csv, breakdown.csv; default out/<sweep file name>)");
  sweep_cmd->add_option("--jobs,-j", sweep_options.jobs, "Runs at once (child processes; default 1)")->check(CLI::Range(1, 1024));
  sweep_cmd->add_option("--threads", sweep_options.threads, "OpenMP threads per run (default: 1 with -j > 1, else all)")
      ->check(CLI::Range(1, 1024));
  auto* manifest_opt = sweep_cmd->add_option("--manifest", sweep_options.manifest,
                        "Write the unfinished runs for GNU parallel (manifest.txt) or Slurm (also sweep.slurm); run nothing")
      ->check(CLI::IsMember({"parallel", "slurm"}));
  sweep_cmd->add_flag("--aggregate-only", sweep_options.aggregate_only, "Only rebuild results.csv and breakdown.csv")
      ->excludes(manifest_opt);
  sweep_cmd->add_flag("--quiet,-q", sweep_options.quiet, "No progress lines on stderr");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "dsnake: error: command line: %s (see dsnake --help)\n", e.what());
    return 2;
  }

  try {
    if (threads > 0) omp_set_num_threads(threads);
    if (*run_cmd) return run(config, overrides, field_cache, options);
    if (*field_cmd) return run_field_command(field_options);
    if (*sweep_cmd) return sweep(sweep_file, sweep_options);
    return validate(validate_config, validate_overrides);
  } catch (const InputError& e) {
    std::fprintf(stderr, "dsnake: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dsnake: internal error: %s\n", e.what());
    return 1;
  }
}
