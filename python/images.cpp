// dsnake.Image, read_image / write_image and read_mesh / write_mesh. An Image owns its voxels
// (float32, as the library's Image<D>); Image.array is a numpy view of them without a copy, in
// the order SimpleITK's GetArrayViewFromImage gives: [z, y, x] (3D) or [y, x] (2D), x fastest.
// spacing and origin are in (x, y, z) order, as SimpleITK's GetSpacing / GetOrigin; direction is
// the D x D matrix whose columns are the voxel axes' directions in world (LPS) coordinates.
#include "python/bindings.h"

#include "framework/core/image.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"

#include <Eigen/LU>  // determinant()
#include <cmath>
#include <cstring>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <variant>

namespace dsnake::python {

namespace {

template <class T>
struct DimensionOf;
template <int D>
struct DimensionOf<Image<D>> {
  static constexpr int value = D;
};

template <int D>
Point<D> vector_from(py::handle object, const std::string& argument, double fallback) {
  Point<D> v = Point<D>::Constant(fallback);
  if (object.is_none()) return v;
  py::array a = checked_array(py::module_::import("numpy").attr("asarray")(object, "float64"), argument, 1);
  if (a.shape(0) != D) raise_input_error(argument, "must have " + std::to_string(D) + " values (x, y" + (D == 3 ? ", z)" : ")"));
  for (int k = 0; k < D; ++k) v[k] = static_cast<const double*>(a.data())[k];
  return v;
}

template <int D>
Grid<D> grid_from(const py::array& voxels, py::handle spacing, py::handle origin, py::handle direction) {
  Grid<D> g;
  for (int k = 0; k < D; ++k) g.size[k] = int(voxels.shape(D - 1 - k));  // [z, y, x]: x is the last numpy axis
  g.spacing = vector_from<D>(spacing, "argument 'spacing'", 1.0);
  if ((g.spacing.array() <= 0).any()) raise_input_error("argument 'spacing'", "must be positive (mm)");
  g.origin = vector_from<D>(origin, "argument 'origin'", 0.0);
  if (!direction.is_none()) {
    py::array m = checked_array(py::module_::import("numpy").attr("ascontiguousarray")(direction, "float64"),
                                "argument 'direction'", 2);
    if (m.shape(0) != D || m.shape(1) != D) raise_input_error("argument 'direction'", "must be a D x D matrix");
    for (int r = 0; r < D; ++r)
      for (int c = 0; c < D; ++c) g.direction(r, c) = static_cast<const double*>(m.data())[r * D + c];
    if (!(g.direction.transpose() * g.direction).isIdentity(1e-6) || g.direction.determinant() < 0)
      raise_input_error("argument 'direction'", "must be a rotation (orthonormal columns, determinant 1)");
  }
  return g;
}

PyImage make_image(py::handle array, py::handle spacing, py::handle origin, py::handle direction) {
  if (!py::isinstance<py::array>(array))
    raise_input_error("argument 'array'", "must be a numpy array of 2 ([y, x]) or 3 ([z, y, x]) dimensions");
  const int ndim = int(py::reinterpret_borrow<py::array>(array).ndim());
  if (ndim != 2 && ndim != 3)
    raise_input_error("argument 'array'", "must have 2 ([y, x]) or 3 ([z, y, x]) dimensions, not " + std::to_string(ndim));
  py::array a = checked_array(array, "argument 'array'", ndim, /*real_dtypes=*/true);
  py::array_t<float> values = py::array_t<float>::ensure(a);  // the one copy, into float32
  std::vector<float> data(values.data(), values.data() + values.size());
  if (ndim == 2) return {Image<2>(grid_from<2>(a, spacing, origin, direction), std::move(data))};
  return {Image<3>(grid_from<3>(a, spacing, origin, direction), std::move(data))};
}

// The voxels as a numpy view; `owner` (the Python Image) stays alive as long as the view.
py::array voxel_view(PyImage& self, py::handle owner) {
  return std::visit(
      [&](auto& image) {
        constexpr int D = DimensionOf<std::decay_t<decltype(image)>>::value;
        std::vector<py::ssize_t> shape, strides;
        py::ssize_t stride = sizeof(float);
        for (int k = 0; k < D; ++k) {
          shape.insert(shape.begin(), image.size()[k]);
          strides.insert(strides.begin(), stride);
          stride *= image.size()[k];
        }
        return py::array(py::dtype::of<float>(), shape, strides, image.data().data(), owner);
      },
      self.image);
}

template <class F>
auto on_grid(const PyImage& self, F f) {
  return std::visit([&](const auto& image) { return f(image.grid()); }, self.image);
}

std::vector<double> as_list(const double* v, int n) { return std::vector<double>(v, v + n); }

PyImage read_image_file(const std::filesystem::path& file) {
  const std::string path = file.string();
  if (image_file_dimension(path) == 2) return {read_image<2>(path)};
  return {read_image<3>(path)};
}

void write_image_file(const PyImage& image, const std::filesystem::path& file, bool label, bool compress) {
  const std::string path = file.string();
  const ImageWriteOptions options{.compress = compress, .label = label};
  std::visit([&](const auto& im) { write_image(im, path, options); }, image.image);
}

py::tuple read_mesh_file(const std::filesystem::path& file, int dimension) {
  const std::string path = file.string();
  if (dimension == 2) return py::make_tuple(points_array<2>(read_contour_template(path).positions), py::none());
  if (dimension != 3) raise_input_error("argument 'dimension'", "must be 2 (a contour) or 3 (a mesh)");
  const Template<3> mesh = read_mesh_template(path);
  std::vector<int> faces;
  for (const auto& t : mesh.connectivity.triangles()) faces.insert(faces.end(), t.begin(), t.end());
  const py::ssize_t f = py::ssize_t(mesh.connectivity.triangles().size());
  return py::make_tuple(points_array<3>(mesh.positions), array_of(std::move(faces), {f, 3}));
}

void write_mesh_file(const std::filesystem::path& file, py::handle vertices, py::handle faces) {
  const std::string path = file.string();
  if (faces.is_none()) {
    write_contour(points_from<2>(vertices, "argument 'vertices'"), path);
    return;
  }
  const PointList<3> points = points_from<3>(vertices, "argument 'vertices'");
  py::array f = checked_array(faces, "argument 'faces'", 2, /*real_dtypes=*/true);
  if (f.shape(1) != 3 || f.dtype().kind() == 'f') raise_input_error("argument 'faces'", "must be an F x 3 integer array");
  py::array_t<int64_t> indices = py::array_t<int64_t>::ensure(f);
  std::vector<Triangle> triangles(f.shape(0));
  for (py::ssize_t i = 0; i < f.shape(0); ++i)
    for (int k = 0; k < 3; ++k) {
      const int64_t v = indices.data()[i * 3 + k];
      if (v < 0 || v >= int64_t(points.size()))
        raise_input_error("argument 'faces'", "row " + std::to_string(i) + " names vertex " + std::to_string(v) +
                                                  " of " + std::to_string(points.size()));
      triangles[i][k] = int(v);
    }
  write_mesh(points, Connectivity::mesh(int(points.size()), std::move(triangles)), path);
}

}  // namespace

void bind_images(py::module_& m) {
  py::class_<PyImage>(m, "Image", R"(An image: float32 voxels on a grid with world (LPS, mm) geometry.

Image(array, spacing=None, origin=None, direction=None) copies `array` (2D [y, x] or 3D [z, y, x],
the order of SimpleITK's GetArrayFromImage, any float or int dtype) into float32; spacing and
origin are (x, y[, z]) in mm (default 1 and 0), direction the D x D rotation whose columns are the
voxel axes in world coordinates (default the identity).)")
      .def(py::init(&make_image), py::arg("array"), py::arg("spacing") = py::none(), py::arg("origin") = py::none(),
           py::arg("direction") = py::none())
      .def_property_readonly(
          "array", [](py::object self) { return voxel_view(self.cast<PyImage&>(), self); },
          "The voxels, float32, [z, y, x] (3D) or [y, x] (2D): a view without a copy; writing it changes the image.")
      .def_property_readonly("dimension", &PyImage::dimension)
      .def_property_readonly("spacing", [](const PyImage& s) {
        return on_grid(s, [](const auto& g) { return as_list(g.spacing.data(), int(g.spacing.size())); });
      }, "Voxel size per axis, (x, y[, z]), mm.")
      .def_property_readonly("origin", [](const PyImage& s) {
        return on_grid(s, [](const auto& g) { return as_list(g.origin.data(), int(g.origin.size())); });
      }, "World (LPS) position of voxel 0, (x, y[, z]), mm.")
      .def_property_readonly("direction", [](const PyImage& s) {
        return on_grid(s, [](const auto& g) {
          const int d = int(g.direction.rows());
          std::vector<double> rows;
          for (int r = 0; r < d; ++r)
            for (int c = 0; c < d; ++c) rows.push_back(g.direction(r, c));
          return py::array(array_of(std::move(rows), {d, d}));
        });
      }, "D x D rotation; column k is voxel axis k's direction in world coordinates.")
      .def("__repr__", [](const PyImage& s) {
        return on_grid(s, [](const auto& g) {
          std::string size;
          for (int k = 0; k < int(g.size.size()); ++k) size += (k ? " x " : "") + std::to_string(g.size[k]);
          return "<dsnake.Image " + size + " voxels (x, y[, z])>";
        });
      });
  m.def("read_image", &read_image_file, py::arg("path"),
        "Reads an image file (NIfTI, MetaImage, NRRD, PNG, DICOM, ...; docs/experiment-file.md) as an Image.");
  m.def("write_image", &write_image_file, py::arg("image"), py::arg("path"), py::arg("label") = false,
        py::arg("compress") = false,
        "Writes an Image by the path's extension; label: as a uint8 label map; compress: zlib / gzip.");
  m.def("read_mesh", &read_mesh_file, py::arg("path"), py::arg("dimension") = 3,
        "Reads a closed mesh (dimension 3: .off .obj .ply .stl .vtk) or contour (2: .txt .json .vtk): "
        "(vertices N x D float64, faces F x 3 int32 or None).");
  m.def("write_mesh", &write_mesh_file, py::arg("path"), py::arg("vertices"), py::arg("faces") = py::none(),
        "Writes a closed mesh (vertices N x 3 float64, faces F x 3 int) or, faces None, a contour "
        "(vertices N x 2 in order) by the path's extension.");
}

}  // namespace dsnake::python
