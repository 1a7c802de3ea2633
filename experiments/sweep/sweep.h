// dsnake sweep: one experiment expanded over methods x parameter grid x corruption levels x
// seeds (the robustness study of §8 and the breakdown points of Figs. 13-18), run in parallel as
// child processes, resumable, and aggregated into one table.
//
// The sweep file (JSON; unknown keys are errors that name the JSON path):
//   {
//     "description": "free text (optional)",
//     "base": "star.json",            // the experiment file, relative to the sweep file
//                                     // (or "builtin:NAME")
//     "grid": {                       // optional: the cartesian product of these overrides
//       "energies[1].weight": [0.1, 0.2],          // key paths as in `dsnake run --set`
//       "field.type": ["gvf", "ddgvf"]},
//     "corruptions": [                // optional: levels, each replaces "corruption"
//       [],
//       [{"type": "outliers", "fraction": 0.01}],
//       [{"type": "noise", "sigma": 30}]],
//     "seeds": [0, 1, 2],             // or {"count": 10, "first": 0}; optional: the base's seed
//     "methods": {                    // optional named variants, in this order
//       "gvf_snake": {"base": "gvf_snake.json", "overrides": {"energies[0].alpha": 0.5}},
//       "dsnake": {"overrides": {}}},
//     "success": {"dice": 0.9}        // optional: replaces every run's "success" thresholds
//   }
// Every run is method x grid point x corruption level x seed; its experiment document is the
// method's base with, in order, the method's overrides, the grid point's, the level's
// "corruption", the seed and "success". Its id "<method>-g<grid>-c<level>-s<seed>-<hash>"
// names the indices and a hash of that document: the same sweep file gives the same ids, and
// editing the base or an override gives the affected runs new ids (and fresh folders).
//
// The output folder:
//   runs/<id>/        the runner's folder (result.json is written last: a run is finished
//                     exactly when runs/<id>/result.json exists). A finished run is reused
//                     only while its result stands: made by this build (result.json's
//                     provenance.build) from input files with the SHA-256 it recorded; otherwise
//                     it runs again, and says why (--keep-stale keeps it, marked in results.csv).
//   configs/<id>.json the resolved experiment (relative file paths made absolute)
//   logs/<id>.log     the run's stderr
//   results.csv       one row per run (written atomically)
//   breakdown.csv     success rate per method x grid point x corruption type x level over seeds,
//                     and each group's breakdown level (first level below 50% success)
//   summary.{csv,md,tex}  per method x grid point x level: n, mean, SD and 95% CI of the metrics
//                     and time, the success rate with its Wilson interval (sweep_summary.h)
//   manifest.txt, sweep.slurm   with --manifest: the unfinished runs as command lines for
//                     GNU parallel (paths relative to the folder; the executable $DSNAKE, by
//                     default the writer's), and a Slurm job-array script whose tasks run
//                     consecutive lines, with --time, --mem and --cpus-per-task from the
//                     finished runs' measured time and memory
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace dsnake {

struct SweepRun {
  std::string id;                 // stable, file-name safe
  std::string method;             // "" when the sweep has no "methods"
  int grid_point = 0;             // index into the cartesian product (last key fastest)
  std::vector<std::pair<std::string, nlohmann::json>> parameters;  // grid key -> value
  int corruption_level = 0;       // index into "corruptions" (0 without it)
  nlohmann::json corruption;      // the run's corruption list ([] when clean)
  uint64_t seed = 0;
  nlohmann::json config;          // the resolved experiment document
  std::string label() const;      // "dsnake/outliers=0.01/seed=3" (grid point included if any)
};

struct Sweep {
  std::string path;                           // the sweep file, for messages
  std::vector<std::string> grid_keys;         // in file order
  std::vector<SweepRun> runs;                 // method, then grid point, level, seed
};

// Reads and expands a sweep file. With `validate`, every (method, grid point, level) is built
// as an experiment once (first seed) so that a bad value fails before anything runs. Throws
// InputError naming the sweep file and the JSON path (or the run and the experiment's path).
Sweep load_sweep(const std::string& path, bool validate = true);

// The resources of the Slurm script (--manifest slurm); 0: derived from the sweep's finished runs
// (sweep.cpp's slurm_resources).
struct SlurmManifestOptions {
  int time_minutes = 0;    // --time of each array task
  int memory_mb = 0;       // --mem of each array task
  int lines_per_task = 0;  // manifest lines (runs) each array task runs one after another
  int max_running = 0;     // array tasks running at once (the array's %N); 0: no cap
};

struct SweepOptions {
  std::string out_dir;
  std::string executable;        // the dsnake binary run for each run (absolute path)
  int jobs = 1;                  // runs at once
  int threads = 0;               // OpenMP threads per run; 0: the cores shared evenly among the jobs (at least 1)
  std::string manifest;          // "", "parallel" or "slurm": write the runs, run nothing
  SlurmManifestOptions slurm;
  bool aggregate_only = false;   // only rebuild results.csv and breakdown.csv
  // Keep finished results that no longer stand (made by another build, or before an input file
  // changed) instead of running them again; they are aggregated with results.csv's "stale" column
  // saying why, and a warning line.
  bool keep_stale = false;
  bool quiet = false;            // no progress lines on stderr
};

struct SweepSummary {
  int total = 0;
  int skipped = 0;      // finished before this invocation
  int completed = 0;    // finished by this invocation
  int failed = 0;       // a run's process failed (see logs/<id>.log); rerun to retry
  int rerun = 0;        // finished before, but their results no longer stood: run again
  int kept_stale = 0;   // finished before, no longer standing, kept (keep_stale)
  bool interrupted = false;
};

// Runs (or writes the manifest of) the unfinished runs, then aggregates. Parallel runs are
// child processes of `options.executable` that die with the sweep, so a killed sweep leaves
// only whole run folders and staging folders that the next invocation removes.
SweepSummary run_sweep(const Sweep& sweep, const SweepOptions& options);

// The aggregates (sweep_report.cpp). `results[i]` is runs[i]'s result.json, or nullopt if
// the run has not finished.
// `stale[i]`: why runs[i]'s result no longer stands ("" when it does, or when absent).
std::string results_csv(const Sweep& sweep, const std::vector<std::optional<nlohmann::json>>& results,
                        const std::vector<std::string>& stale = {});
std::string breakdown_csv(const Sweep& sweep, const std::vector<std::optional<nlohmann::json>>& results);

// A corruption list as a label and its place on a severity axis: [] -> ("clean", "clean", 0);
// [{"type":"outliers","fraction":0.01}] -> ("outliers", "outliers=0.01", 0.01). A list of
// several corruptions has the type "noise+perturb" and its level index as magnitude.
struct CorruptionLevel {
  std::string type, label;
  double magnitude = 0;
};
CorruptionLevel describe_corruption(const nlohmann::json& list, int level_index);

}  // namespace dsnake
