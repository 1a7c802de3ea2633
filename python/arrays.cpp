// The checks on numpy arrays handed to the module: what a C++ function would otherwise read out
// of bounds or compute NaN from becomes a dsnake.InputError naming the argument.
#include "python/bindings.h"

#include <cmath>

namespace dsnake::python {

py::array checked_array(py::handle object, const std::string& argument, int ndim, bool real_dtypes) {
  if (!py::isinstance<py::array>(object))
    raise_input_error(argument, "must be a numpy array, not " +
                                    py::str(py::type::handle_of(object).attr("__name__")).cast<std::string>());
  py::array a = py::reinterpret_borrow<py::array>(object);
  const char kind = a.dtype().kind();
  const bool ok = real_dtypes ? (kind == 'f' || kind == 'i' || kind == 'u') : a.dtype().is(py::dtype::of<double>());
  if (!ok)
    raise_input_error(argument, std::string("must have dtype ") + (real_dtypes ? "float or int" : "float64") +
                                    ", not " + py::str(a.dtype()).cast<std::string>());
  if (a.ndim() != ndim)
    raise_input_error(argument, "must have " + std::to_string(ndim) + " dimensions, not " + std::to_string(a.ndim()));
  if (!(a.flags() & py::array::c_style))
    raise_input_error(argument, "must be C-contiguous (numpy.ascontiguousarray makes a copy that is)");
  if (kind == 'f') {
    py::object finite = py::module_::import("numpy").attr("isfinite")(a).attr("all")();
    if (!finite.cast<bool>()) raise_input_error(argument, "holds NaN or infinite values");
  }
  return a;
}

template <int D>
PointList<D> points_from(py::handle object, const std::string& argument) {
  py::array a = checked_array(object, argument, 2);
  if (a.shape(1) != D)
    raise_input_error(argument, "must have shape (n, " + std::to_string(D) + "), not (" + std::to_string(a.shape(0)) +
                                    ", " + std::to_string(a.shape(1)) + ")");
  const double* p = static_cast<const double*>(a.data());
  PointList<D> points(a.shape(0));
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    for (int k = 0; k < D; ++k) points[i][k] = p[i * D + k];
  return points;
}

template PointList<2> points_from<2>(py::handle, const std::string&);
template PointList<3> points_from<3>(py::handle, const std::string&);

}  // namespace dsnake::python
