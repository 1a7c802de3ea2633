// dsnake.schema() and dsnake.sweep(): the experiment file's JSON Schema, and a sweep run as the
// command line runs it (each run a child process of the dsnake executable built with this
// module), read back from its results.csv.
#include "python/bindings.h"

#include "experiments/spec/schema.h"
#include "experiments/sweep/sweep.h"

#include <filesystem>

#ifndef DSNAKE_CLI_EXECUTABLE
#error "DSNAKE_CLI_EXECUTABLE: the dsnake executable that runs a sweep's runs (python/CMakeLists.txt)"
#endif

namespace dsnake::python {

namespace {

py::object sweep(py::handle config, py::handle out, int jobs) {
  if (jobs < 1) raise_input_error("argument 'jobs'", "must be at least 1");
  const auto fspath = py::module_::import("os").attr("fspath");
  const std::string file = py::str(fspath(config)).cast<std::string>();
  SweepOptions options;
  options.out_dir = py::str(fspath(out)).cast<std::string>();
  options.executable = DSNAKE_CLI_EXECUTABLE;
  options.jobs = jobs;
  options.quiet = true;
  SweepSummary summary;
  {
    py::gil_scoped_release release;
    summary = run_sweep(load_sweep(file), options);
  }
  if (summary.interrupted) {  // Ctrl-C, caught by the sweep to stop its children
    PyErr_SetNone(PyExc_KeyboardInterrupt);
    throw py::error_already_set();
  }
  const std::string table = (std::filesystem::path(options.out_dir) / "results.csv").string();
  py::list rows = py::module_::import("builtins").attr("list")(
      py::module_::import("csv").attr("DictReader")(py::module_::import("builtins").attr("open")(table)));
  try {
    return py::module_::import("pandas").attr("DataFrame")(rows);
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_ImportError)) throw;
  }
  return rows;
}

}  // namespace

void bind_sweep(py::module_& m) {
  m.def("schema", [] { return to_python(experiment_schema()); },
        "The experiment file's JSON Schema (draft 2020-12) as a dict: every key with its unit, default and range.");
  m.def("sweep", &sweep, py::arg("config"), py::arg("out"), py::arg("jobs") = 1,
        R"(Runs a sweep file (docs/experiment-file.md, "Sweeps") into the folder `out`, as
`dsnake sweep CONFIG --out OUT --jobs JOBS`: runs already finished there are kept. Returns
results.csv as a pandas DataFrame when pandas is installed, else a list of dicts (strings).)");
}

}  // namespace dsnake::python
