// dsnake.run(): an experiment run through the runner (experiments/output/runner.h), with or
// without its output folder, and its Result as numpy arrays. The GIL is released while the run
// computes; the progress callback takes it back for each call.
#include "python/bindings.h"

#include "experiments/output/report_step.h"
#include "experiments/output/runner.h"
#include "experiments/spec/experiment.h"
#include "framework/core/errors.h"

#include <exception>
#include <filesystem>
#include <optional>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

namespace dsnake::python {

namespace {

// A path, "builtin:NAME", an os.PathLike or a dict in the experiment-file format.
ExperimentFile load_config(py::handle config) {
  if (py::isinstance<py::dict>(config)) {
    ExperimentFile file;
    file.path = "config";  // errors name the dict as "config: <key>: ..."
    file.document = from_python(config, "argument 'config'");
    const auto d = file.document.find("dimension");
    if (d == file.document.end() || !d->is_number_integer() || (d->get<int>() != 2 && d->get<int>() != 3))
      throw InputError(file.path, "dimension", "is required: 2 or 3");
    file.dimension = d->get<int>();
    return file;
  }
  if (!py::isinstance<py::str>(config) && !py::hasattr(config, "__fspath__"))
    raise_input_error("argument 'config'", "must be a path, 'builtin:NAME' or a dict, not " +
                                               py::str(py::type::handle_of(config).attr("__name__")).cast<std::string>());
  const std::string text = py::str(py::module_::import("os").attr("fspath")(config)).cast<std::string>();
  if (text.rfind("builtin:", 0) == 0) return builtin_experiment(text.substr(8));
  return load_experiment_file(text);
}

// Thrown through the registration when the progress callback raised: the Python exception is
// kept aside and raised again once the GIL is back.
struct StopRun {};

py::dict iteration_dict(const IterationInfo& info) {
  py::dict d;
  d["phase"] = info.phase;
  d["iteration"] = info.iteration;
  d["phase_iteration"] = info.phase_iteration;
  d["energy"] = info.total_energy;
  d["energy_terms"] = info.energy_terms;
  d["max_move"] = info.max_displacement;
  d["vertices"] = info.vertices;
  return d;
}

// The trace as columns, one row per iteration (energy_trace.csv's columns).
py::dict trace_columns(const std::vector<IterationInfo>& trace, const std::vector<std::string>& names) {
  const size_t n = trace.size();
  std::vector<int> iteration(n), phase(n), phase_iteration(n), vertices(n);
  std::vector<double> move(n), total(n);
  std::vector<std::vector<double>> terms(names.size(), std::vector<double>(n, NAN));
  for (size_t i = 0; i < n; ++i) {
    iteration[i] = trace[i].iteration;
    phase[i] = trace[i].phase;
    phase_iteration[i] = trace[i].phase_iteration;
    vertices[i] = trace[i].vertices;
    move[i] = trace[i].max_displacement;
    total[i] = trace[i].total_energy;
    for (size_t t = 0; t < names.size() && t < trace[i].energy_terms.size(); ++t) terms[t][i] = trace[i].energy_terms[t];
  }
  const py::ssize_t rows = py::ssize_t(n);
  py::dict d;
  d["iteration"] = array_of(std::move(iteration), {rows});
  d["phase"] = array_of(std::move(phase), {rows});
  d["phase_iteration"] = array_of(std::move(phase_iteration), {rows});
  d["vertices"] = array_of(std::move(vertices), {rows});
  d["max_displacement"] = array_of(std::move(move), {rows});
  for (size_t t = 0; t < names.size(); ++t) d[py::str(names[t])] = array_of(std::move(terms[t]), {rows});
  d["total"] = array_of(std::move(total), {rows});
  return d;
}

// 2D: the vertex indices along the contour from vertex 0 (the polygon's "next" neighbours).
std::vector<int> contour_order(const Connectivity& c) {
  std::vector<int> order;
  if (c.num_vertices() == 0) return order;
  order.reserve(c.num_vertices());
  int v = 0;
  do {
    order.push_back(v);
    v = c.neighbors(v)[1];
  } while (v != 0 && int(order.size()) < c.num_vertices());
  return order;
}

// correspondence.csv's columns: per template vertex its start, end and target (world mm; NaN where
// the vertex was removed or has no target) and its error (mm).
template <int D>
py::dict correspondence_columns(const Experiment<D>& ex, const RunOutcome<D>& outcome) {
  const Grid<D>& frame = ex.image.grid();
  const int n = ex.tmpl.num_vertices();
  PointList<D> start(n), end(n), target(n);
  std::vector<double> error(n, NAN);
  std::vector<int> ids(n);
  for (int t = 0; t < n; ++t) {
    ids[t] = t;
    const int v = outcome.snake.vertex_of_template_id(t);
    start[t] = frame.to_world(ex.initial[t]);
    end[t] = v >= 0 ? outcome.final_world[v] : Point<D>::Constant(NAN);
    const bool has = t < int(ex.truth.targets.size()) && ex.truth.targets[t];
    target[t] = has ? frame.to_world(*ex.truth.targets[t]) : Point<D>::Constant(NAN);
    if (t < int(outcome.correspondence.per_vertex.size())) error[t] = outcome.correspondence.per_vertex[t];
  }
  py::dict d;
  d["template_id"] = array_of(std::move(ids), {py::ssize_t(n)});
  d["initial"] = points_array<D>(start);
  d["final"] = points_array<D>(end);
  d["target"] = points_array<D>(target);
  d["error"] = array_of(std::move(error), {py::ssize_t(n)});
  return d;
}

template <int D>
py::object result_object(const Experiment<D>& ex, const RunOutcome<D>& outcome) {
  py::object result = py::module_::import("types").attr("SimpleNamespace")();
  const Snake<D>& snake = outcome.snake;
  result.attr("dimension") = D;
  result.attr("vertices") = points_array<D>(outcome.final_world);
  if constexpr (D == 3) {
    std::vector<int> faces;
    for (const auto& t : snake.connectivity().triangles()) faces.insert(faces.end(), t.begin(), t.end());
    const py::ssize_t f = py::ssize_t(snake.connectivity().triangles().size());
    result.attr("faces") = array_of(std::move(faces), {f, 3});
    result.attr("order") = py::none();
  } else {
    result.attr("faces") = py::none();
    std::vector<int> order = contour_order(snake.connectivity());
    const py::ssize_t n = py::ssize_t(order.size());
    result.attr("order") = array_of(std::move(order), {n});
  }
  std::vector<int> ids = snake.template_ids();
  result.attr("template_ids") = array_of(std::move(ids), {py::ssize_t(snake.num_vertices())});
  result.attr("correspondence") = correspondence_columns(ex, outcome);
  py::object document = to_python(outcome.result);
  result.attr("metrics") = document["metrics"];
  result.attr("success") = document["success"];
  result.attr("status") = document["status"];
  result.attr("trace") = trace_columns(outcome.trace, outcome.term_names);
  result.attr("config") = document["config"];
  result.attr("result") = document;  // result.json's whole document
  return result;
}

// The command line's line for a diverged run (experiments/cli/main.cpp).
std::string divergence_line(const nlohmann::ordered_json& result) {
  std::string where;
  if (const auto d = result.find("divergence"); d != result.end() && d->is_object())
    where = " in phase " + d->value("phase", std::string("?")) + " at iteration " +
            std::to_string(d->value("phase_iteration", 0)) + ": " + d->value("reason", std::string());
  return "the run diverged" + where;
}

template <int D>
py::object run_dimension(const ExperimentFile& file, const RunOptions& options, bool write,
                         std::exception_ptr& raised) {
  std::optional<Experiment<D>> ex;
  RunOutcome<D> outcome;
  try {
    py::gil_scoped_release release;
    ex.emplace(make_experiment<D>(file));
    outcome = write ? run_experiment_outcome(*ex, options) : compute_experiment(*ex, options);
    // With `out`, the same report step as `dsnake run` (experiments/output/report_step.h).
    if (write && ex->output.figures && ex->output.report) write_report(options.out_dir);
  } catch (const StopRun&) {
    std::rethrow_exception(raised);
  }
  py::object result = result_object(*ex, outcome);
  if (outcome.result.value("status", "") == "diverged") {
    py::object error = divergence_error_class()(divergence_line(outcome.result));
    error.attr("result") = result;
    PyErr_SetObject(divergence_error_class().ptr(), error.ptr());
    throw py::error_already_set();
  }
  return result;
}

py::object run(py::handle config, py::handle out, py::handle progress) {
  const ExperimentFile file = load_config(config);
  RunOptions options;
  options.quiet = true;
  // result.json's provenance: the call, with the config's path (or "<dict>")
  options.command_line = {"dsnake.run", py::isinstance<py::dict>(config) ? std::string("<dict>") : py::str(config).cast<std::string>()};
  const bool write = !out.is_none();
  if (write) options.out_dir = py::str(py::module_::import("os").attr("fspath")(out)).cast<std::string>();
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    raise_input_error("argument 'progress'", "must be callable");
  std::exception_ptr raised;
  py::object callback = py::reinterpret_borrow<py::object>(progress);
  // Every iteration also looks for Ctrl-C, so that an interrupt stops a run like an exception
  // raised in the callback.
  options.on_iteration = [&](const IterationInfo& info) {
    py::gil_scoped_acquire gil;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (!callback.is_none()) callback(iteration_dict(info));
    } catch (py::error_already_set&) {
      raised = std::current_exception();
      throw StopRun{};
    }
  };
  if (file.dimension == 2) return run_dimension<2>(file, options, write, raised);
  return run_dimension<3>(file, options, write, raised);
}

// dsnake.report(folder): the report step on a run's or a sweep's folder; its path.
std::string report(py::handle folder) {
  const std::string dir = py::str(py::module_::import("os").attr("fspath")(folder)).cast<std::string>();
  namespace fs = std::filesystem;
  if (!fs::is_regular_file(fs::path(dir) / "result.json") && !fs::is_regular_file(fs::path(dir) / "results.csv"))
    raise_input_error("argument 'folder'", dir + ": neither a run folder (result.json) nor a sweep folder (results.csv)");
  bool written = false;
  {
    py::gil_scoped_release release;
    written = write_report(dir, {.quiet = true});
  }
  if (!written)
    throw std::runtime_error(dir + "/report.html was not written (python3 with matplotlib: scripts/setup.sh)");
  return (fs::path(dir) / "report.html").string();
}

}  // namespace

void bind_run(py::module_& m) {
  m.def("report", &report, py::arg("folder"),
        R"(Writes folder/report.html (and, for a run, its matplotlib figures) and returns its path:
what `dsnake report FOLDER` does (docs/reports.md). folder: a run's output folder (result.json)
or a sweep's (results.csv). Raises dsnake.InputError for any other folder, RuntimeError when the
report could not be written.)");
  m.def("run", &run, py::arg("config"), py::arg("out") = py::none(), py::arg("progress") = py::none(),
        R"(Runs an experiment and returns its Result.

config: a path to an experiment file, "builtin:NAME" (default, classical, ellipsoid) or a dict in
    the experiment-file format (docs/experiment-file.md; relative paths resolve against the
    current folder).
out: a folder: the run writes the same files there as `dsnake run CONFIG --out OUT`. None: nothing
    touches the disk.
progress: called after every iteration with a dict (phase, iteration, phase_iteration, energy,
    energy_terms, max_move in mm, vertices); an exception raised in it stops the run (nothing is
    written) and propagates.

Result: vertices (N x D float64, world mm), faces (3D: F x 3 int32; 2D: None), order (2D: the
vertex indices along the contour; 3D: None), template_ids (N, -1 for inserted vertices),
correspondence (dict of columns per template vertex: template_id, initial, final, target, error),
metrics (dict), success, status, trace (dict of numpy columns, one row per iteration), config
(the experiment as run) and result (result.json's whole document).

Raises dsnake.InputError for bad input and dsnake.DivergenceError (with .result) when the
watchdog stops the run; the GIL is released while the run computes.)");
}

}  // namespace dsnake::python
