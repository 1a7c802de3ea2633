// The pieces of the Python module `dsnake` (docs/python.md), one file per topic, and what they
// share: the module's exception classes and the conversion of nlohmann JSON to Python objects.
#pragma once

#include "framework/core/image.h"
#include "framework/core/types.h"

#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <string>
#include <variant>
#include <vector>

namespace dsnake::python {

namespace py = pybind11;

// dsnake.Error and its subclasses dsnake.InputError (bad input: the CLI's exit code 2) and
// dsnake.DivergenceError (a run stopped by the watchdog: exit code 3).
py::object error_class();
py::object input_error_class();
py::object divergence_error_class();

// Raises dsnake.InputError naming a Python argument or key ("argument 'config'").
[[noreturn]] void raise_input_error(const std::string& where, const std::string& message);

py::object to_python(const nlohmann::ordered_json& j);
nlohmann::json from_python(py::handle object, const std::string& where);

// numpy arrays in: a C-contiguous float64 (or, for `real_dtypes`, any float or integer dtype)
// array of the given number of dimensions, every value finite; anything else raises
// dsnake.InputError naming `argument`.
py::array checked_array(py::handle object, const std::string& argument, int ndim, bool real_dtypes = false);
// An n x D float64 array of positions (mm).
template <int D>
PointList<D> points_from(py::handle object, const std::string& argument);

// numpy arrays out, owning their values.
template <class T>
py::array_t<T> array_of(std::vector<T> values, std::vector<py::ssize_t> shape) {
  auto* owner = new std::vector<T>(std::move(values));
  py::capsule free_when_done(owner, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owner->data(), free_when_done);
}
template <int D>
py::array_t<double> points_array(const PointList<D>& points) {
  std::vector<double> flat;
  flat.reserve(points.size() * D);
  for (const auto& p : points) flat.insert(flat.end(), p.data(), p.data() + D);
  return array_of(std::move(flat), {py::ssize_t(points.size()), D});
}

// dsnake.Image: the library's image, 2D or 3D (images.cpp).
struct PyImage {
  std::variant<Image<2>, Image<3>> image;
  int dimension() const { return image.index() == 0 ? 2 : 3; }
};

void bind_run(py::module_& m);
void bind_images(py::module_& m);
void bind_sweep(py::module_& m);
void bind_plugins(py::module_& m);

}  // namespace dsnake::python
