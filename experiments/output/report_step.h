// The report of a run's or a sweep's output folder: the matplotlib figures (energy terms,
// convergence, for a mesh a rendering coloured by its error) and a self-contained
// report.html with the tables and an interactive 3D view, written by
// scripts/report/make_report.py (docs/reports.md) in a child python3 process. The registration
// library writes only data and its raster figures; `dsnake run`, `dsnake sweep` and
// `dsnake report` call this step on the folder they finished.
#pragma once

#include <string>

namespace dsnake {

// The files the step writes into a run folder; a run into the same folder removes an earlier
// run's (experiments/output/output_folder.h).
inline constexpr const char* kReportFiles[] = {"report.html", "energy.png", "convergence.png", "render.png"};

// Where the step finds python3 and the scripts: $DSNAKE_PYTHON, else /usr/bin/python3 (Debian's,
// with python3-matplotlib and python3-vtk9); $DSNAKE_SCRIPTS_DIR, else this source tree's
// scripts/. The viewer bundle is found by make_report.py ($DSNAKE_VIEWER_JS, else the build's
// viewer/dsnake_viewer.js), whose path is handed to it here.
struct ReportStepOptions {
  bool quiet = false;  // no warning line when the report cannot be written
};

// Runs make_report.py on `folder` (a run folder with result.json, or a sweep folder with
// results.csv) and waits for it; its stdout and stderr are this process's. Returns true when it
// exited 0. Otherwise, unless quiet, prints one line on stderr saying that the report of
// `folder` was not written and why (the script's own line above it names the file); the folder's
// other outputs are untouched either way.
bool write_report(const std::string& folder, const ReportStepOptions& options = {});

}  // namespace dsnake
