// The Python module `dsnake`: its exception classes, the translation of the library's
// exceptions into them (the same one-line messages as the command line's), and the bindings.
#include "python/bindings.h"

#include "experiments/cli/heap_settings.h"
#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <cstdlib>
#include <stdexcept>

namespace dsnake::python {

namespace {

py::object& stored(int which) {
  static py::object classes[3];
  return classes[which];
}

}  // namespace

py::object error_class() { return stored(0); }
py::object input_error_class() { return stored(1); }
py::object divergence_error_class() { return stored(2); }

void raise_input_error(const std::string& where, const std::string& message) {
  throw InputError("", where, message);
}

py::object to_python(const nlohmann::ordered_json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

nlohmann::json from_python(py::handle object, const std::string& where) {
  std::string text;
  try {
    // allow_nan=False: JSON has no NaN, and the experiment file's reader would refuse it too.
    text = py::module_::import("json").attr("dumps")(object, py::arg("allow_nan") = false).cast<std::string>();
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_TypeError) && !e.matches(PyExc_ValueError)) throw;
    raise_input_error(where, std::string("not an experiment document in JSON terms: ") + e.what());
  }
  return nlohmann::json::parse(text);
}

}  // namespace dsnake::python

PYBIND11_MODULE(_dsnake, m) {
  namespace py = pybind11;
  using namespace dsnake::python;
  m.doc() =
      "D-Snake registration (Levi & Gotsman): register a template shape to an image.\n\n"
      "run() runs an experiment (a file, 'builtin:NAME' or a dict in the experiment-file format,\n"
      "docs/experiment-file.md) and returns its Result; errors raise dsnake.Error.";
  stored(0) = py::reinterpret_steal<py::object>(PyErr_NewExceptionWithDoc(
      "dsnake.Error", "Every error of dsnake; the message is the command line's one line.", PyExc_RuntimeError, nullptr));
  stored(1) = py::reinterpret_steal<py::object>(PyErr_NewExceptionWithDoc(
      "dsnake.InputError", "Bad input: a file, a key or an argument; the message names it.", stored(0).ptr(), nullptr));
  stored(2) = py::reinterpret_steal<py::object>(PyErr_NewExceptionWithDoc(
      "dsnake.DivergenceError", "A run stopped by the watchdog; .result holds the Result of its last good positions.",
      stored(0).ptr(), nullptr));
  // glibc's malloc as the dsnake executable sets it (experiments/cli/heap_settings.h): volume-sized
  // buffers go back to the system when freed, and a remeshed mesh's arrays do not fault their
  // pages in again at every remeshing.
  dsnake::configure_heap(std::getenv("GLIBC_TUNABLES"));
  m.attr("Error") = stored(0);
  m.attr("InputError") = stored(1);
  m.attr("DivergenceError") = stored(2);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const dsnake::InputError& e) {
      PyErr_SetString(stored(1).ptr(), e.what());
    } catch (const dsnake::OutputError& e) {
      PyErr_SetString(stored(0).ptr(), e.what());
    } catch (const std::logic_error& e) {  // DSNAKE_ASSERT: a bug, not the input's fault
      PyErr_SetString(stored(0).ptr(), (std::string("internal error: ") + e.what()).c_str());
    } catch (const py::builtin_exception&) {  // pybind11's own (ValueError, TypeError): its translator's
      throw;
    } catch (const std::runtime_error& e) {
      PyErr_SetString(stored(0).ptr(), e.what());
    }
  });
  bind_run(m);
  bind_images(m);
  bind_sweep(m);
  bind_plugins(m);
}
