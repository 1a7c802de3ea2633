// Runs an experiment as a snake and writes its output folder:
//   result.json          metrics, success, iterations, vertices, timings, config, version
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

#include <nlohmann/json.hpp>
#include <string>

namespace dsnake {

struct RunOptions {
  std::string out_dir;   // created if missing
  bool quiet = false;    // no progress lines on stderr
  bool force = false;    // write into a non-empty folder that holds no earlier result (experiments/output/output_folder.h)
};

// Runs and writes the outputs; returns the result document (as written to result.json).
template <int D>
nlohmann::ordered_json run_experiment(Experiment<D>& experiment, const RunOptions& options);

// The version string written into result.json.
std::string dsnake_version();

}  // namespace dsnake
