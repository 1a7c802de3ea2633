// Runs an experiment as a snake and writes its output folder:
//   result.json          metrics, success, iterations, vertices, timings, config, version,
//                        provenance (experiments/output/provenance.h)
//   final.{vtk,ply|txt}  the final snake (VTK with template_id and displacement scalars)
//   initial.{vtk,...}    the placed template
//   correspondence.csv   each template vertex's initial and final position (and target, error)
//   energy_trace.csv     per iteration: phase, vertices, largest move, each weighted term, total
//   snapshots/           the snake every n iterations (output.snapshot_every)
//   *.png                figures: 2D overlay / 3D orthogonal slices (template yellow, result
//                        red), energy curves
// Everything is written into a staging folder beside the output folder and moved in at the
// end, result.json last, so a failed run leaves nothing half-written in the output folder.
#pragma once

#include "experiments/spec/experiment.h"

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace dsnake {

struct RunOptions {
  std::string out_dir;   // created if missing
  bool quiet = false;    // no progress lines on stderr
  bool force = false;    // write into a non-empty folder that holds no earlier result (experiments/output/output_folder.h)
  // Called after every iteration, on the thread that runs the registration; an exception thrown
  // in it ends the run (nothing is written) and propagates to the caller.
  std::function<void(const IterationInfo&)> on_iteration = {};
  // The command that ran the experiment, as given: result.json's provenance.command_line.
  std::vector<std::string> command_line = {};
};

// What a run computed, before anything is written.
template <int D>
struct RunOutcome {
  nlohmann::ordered_json result;       // result.json's document
  Snake<D> snake;                      // the snake at the end, in the image's frame
  PointList<D> final_world;            // its positions in world coordinates (mm)
  std::vector<IterationInfo> trace;    // one row per iteration (energy_trace.csv)
  std::vector<std::string> term_names; // the trace's energy columns
  CorrespondenceError correspondence;  // per template vertex, against the ground truth's targets
};

// run_experiment, also handing back the snake and the trace.
template <int D>
RunOutcome<D> run_experiment_outcome(Experiment<D>& experiment, const RunOptions& options);

// Runs the experiment without touching the disk (output.snapshot_every is ignored): the same
// computation as run_experiment, which writes its files from it.
template <int D>
RunOutcome<D> compute_experiment(Experiment<D>& experiment, const RunOptions& options);

// Runs and writes the outputs; returns the result document (as written to result.json).
template <int D>
nlohmann::ordered_json run_experiment(Experiment<D>& experiment, const RunOptions& options);

// The version string written into result.json.
std::string dsnake_version();

}  // namespace dsnake
