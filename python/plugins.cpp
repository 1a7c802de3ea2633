// dsnake.field() and dsnake.energy(): every registered external field and energy
// (fields/registry.h, energies/registry.h), built from keyword options read as the experiment
// file's "field" and "energies" objects are, so that a new optimiser or an ablation can be tried
// in Python on the library's own terms. Their docstrings list every type's keys, units and ranges
// from the options' declarations (Registry::Entry::rows).
#include "python/bindings.h"

#include "energies/registry.h"
#include "fields/registry.h"
#include "framework/core/energy.h"
#include "framework/core/errors.h"
#include "framework/core/json_reader.h"

#include <memory>
#include <optional>

namespace dsnake::python {

namespace {

PyImage& image_argument(py::handle image, const std::string& argument = "argument 'image'") {
  if (!py::isinstance<PyImage>(image)) raise_input_error(argument, "must be a dsnake.Image");
  return image.cast<PyImage&>();
}

nlohmann::json options_document(const std::string& type, const py::kwargs& options, const std::string& where) {
  nlohmann::json document = from_python(options, where);
  if (document.contains("type")) raise_input_error(where, "give the type as the argument 'type', not as an option");
  document["type"] = type;
  return document;
}

template <int D>
std::unique_ptr<ExternalField<D>> computed_field(const Image<D>& image, const nlohmann::json& document) {
  JsonReader reader(document, "", "field");
  auto field = build_field(read_field_spec<D>(reader));
  py::gil_scoped_release release;
  field->check_grid(image.grid());
  field->compute(image);
  return field;
}

// The field's vectors as a float32 array [z, y, x, D] ([y, x, D] in 2D), components in (x, y, z) order.
template <int D>
py::array field_array(const Image<D>& image, const nlohmann::json& document) {
  const auto field = computed_field<D>(image, document);
  const VectorField<D>& v = field->vectors();
  std::vector<py::ssize_t> shape{D};
  for (int k = 0; k < D; ++k) shape.insert(shape.begin(), v.grid().size[k]);
  return array_of(std::vector<float>(v.data()), shape);
}

py::array field(py::handle image, const std::string& type, const py::kwargs& options) {
  const nlohmann::json document = options_document(type, options, "field");
  return std::visit([&](const auto& im) { return field_array(im, document); }, image_argument(image).image);
}

// An energy bound to a template (and, for the terms that read it, an image and its field).
template <int D>
struct BoundEnergy {
  Template<D> tmpl;
  std::optional<Image<D>> image;
  std::optional<Image<D>> reference;  // the atlas image, in which the template lies on its object
  std::unique_ptr<ExternalField<D>> field;
  std::unique_ptr<Energy<D>> energy;
  Snake<D> snake;  // on the template's connectivity; its positions are each call's q

  Snake<D>& at(py::handle q) {
    PointList<D> points = points_from<D>(q, "argument 'q'");
    if (int(points.size()) != tmpl.num_vertices())
      raise_input_error("argument 'q'", "must have one row per template vertex (" + std::to_string(tmpl.num_vertices()) +
                                            "), not " + std::to_string(points.size()));
    snake.positions() = std::move(points);
    return snake;
  }
  double value(py::handle q) { return energy->value(at(q)); }
  py::array propose(py::handle q) {
    Snake<D>& s = at(q);
    PointList<D> out = s.positions();
    energy->propose(s, out);
    return points_array<D>(out);
  }
};

template <int D>
Template<D> template_from(py::handle object) {
  Template<D> t;
  if constexpr (D == 2) {
    t.positions = points_from<2>(object, "argument 'template'");
    t.connectivity = Connectivity::polygon(int(t.positions.size()));
  } else {
    const py::sequence pair = py::reinterpret_borrow<py::sequence>(object);
    if (py::len(pair) != 2) raise_input_error("argument 'template'", "3D: a tuple (vertices, faces)");
    t.positions = points_from<3>(pair[0], "argument 'template' (vertices)");
    py::array f = checked_array(pair[1], "argument 'template' (faces)", 2, /*real_dtypes=*/true);
    if (f.shape(1) != 3 || f.dtype().kind() == 'f')
      raise_input_error("argument 'template' (faces)", "must be an F x 3 integer array");
    py::array_t<int64_t> idx = py::array_t<int64_t>::ensure(f);
    std::vector<Triangle> triangles(f.shape(0));
    for (py::ssize_t i = 0; i < f.shape(0); ++i)
      for (int k = 0; k < 3; ++k) {
        const int64_t v = idx.data()[i * 3 + k];
        if (v < 0 || v >= int64_t(t.positions.size()))
          raise_input_error("argument 'template' (faces)", "row " + std::to_string(i) + " names vertex " + std::to_string(v));
        triangles[i][k] = int(v);
      }
    t.connectivity = Connectivity::mesh(int(t.positions.size()), std::move(triangles));
    if (const std::string problem = t.connectivity.closed_manifold_problem(); !problem.empty())
      raise_input_error("argument 'template'", "not a closed oriented manifold mesh: " + problem);
  }
  if (t.positions.size() < 3) raise_input_error("argument 'template'", "needs at least 3 vertices");
  return t;
}

template <int D>
std::shared_ptr<BoundEnergy<D>> bind_energy(const std::string& type, py::handle tmpl, py::handle image,
                                            py::handle field_options, py::handle reference,
                                            const py::kwargs& options) {
  auto bound = std::make_shared<BoundEnergy<D>>();
  bound->tmpl = template_from<D>(tmpl);
  const nlohmann::json document = options_document(type, options, "energy");
  JsonReader reader(document, "", "energy");
  bound->energy = energy_registry<D>().create(reader);
  bound->energy->check_template(bound->tmpl);
  EnergyContext<D> context;
  context.tmpl = &bound->tmpl;
  if (!reference.is_none()) {
    PyImage& im = image_argument(reference, "argument 'reference'");
    if (im.dimension() != D) raise_input_error("argument 'reference'", "must have the template's dimension");
    bound->reference = std::get<Image<D>>(im.image);
    context.reference_image = &*bound->reference;
  } else if (bound->energy->needs_reference_image()) {
    raise_input_error("argument 'reference'", "\"" + type + "\" needs a reference image (an atlas image in which the template lies on its object)");
  }
  if (!image.is_none()) {
    PyImage& im = image_argument(image, "argument 'image'");
    if (im.dimension() != D) raise_input_error("argument 'image'", "must have the template's dimension");
    bound->image = std::get<Image<D>>(im.image);
    py::dict field = field_options.is_none() ? py::dict(py::arg("type") = "gvf") : field_options.cast<py::dict>();
    bound->field = computed_field<D>(*bound->image, from_python(field, "argument 'field'"));
    context.image = &*bound->image;
    context.field = bound->field.get();
  }
  bound->snake = Snake<D>::from_template(bound->tmpl, bound->tmpl.positions);
  bound->energy->bind(context, bound->snake);
  bound->energy->begin_phase(bound->snake);
  return bound;
}

struct PyEnergy {
  std::variant<std::shared_ptr<BoundEnergy<2>>, std::shared_ptr<BoundEnergy<3>>> bound;
};

PyEnergy energy(const std::string& type, py::handle tmpl, py::handle image, py::handle field_options,
                py::handle reference, const py::kwargs& options) {
  const bool three_d = py::isinstance<py::tuple>(tmpl) || py::isinstance<py::list>(tmpl);
  if (three_d) return {bind_energy<3>(type, tmpl, image, field_options, reference, options)};
  return {bind_energy<2>(type, tmpl, image, field_options, reference, options)};
}

// Every type of the 2D and 3D registries with its summary and its keys: name (type, unit) =
// default, range: help.
template <class Product2, class Product3>
std::string catalogue(const Registry<Product2>& two, const Registry<Product3>& three) {
  std::string text;
  auto add = [&](const auto& registry, const std::string& name, const std::string& only) {
    const auto& entry = registry.entry(name);
    text += "\n" + name + only + ": " + entry.summary + "\n";
    for (const KeyRow& row : entry.rows) {
      text += "    " + row.name + " (" + row.type + (row.unit.empty() ? "" : ", " + row.unit) + ")";
      if (!row.default_value.empty()) text += " = " + row.default_value;
      if (!row.range.empty()) text += ", " + row.range;
      text += ": " + row.help + "\n";
    }
  };
  for (const auto& name : two.names()) add(two, name, three.contains(name) ? "" : " (2D only)");
  for (const auto& name : three.names())
    if (!two.contains(name)) add(three, name, " (3D only)");
  return text;
}

// The same catalogue as data, for the type stubs' generator (python/generate_stubs.py): per type its
// summary, the dimensions it exists in, its key table and its keys' JSON Schema.
template <class Product2, class Product3>
py::list catalogue_data(const Registry<Product2>& two, const Registry<Product3>& three) {
  py::list types;
  auto add = [&](const auto& registry, const std::string& name, py::list dimensions) {
    const auto& entry = registry.entry(name);
    py::list keys;
    for (const KeyRow& row : entry.rows) {
      py::dict key;
      key["name"] = row.name;
      key["type"] = row.type;
      key["unit"] = row.unit;
      key["default"] = row.default_value;
      key["range"] = row.range;
      key["help"] = row.help;
      keys.append(key);
    }
    py::dict type;
    type["name"] = name;
    type["summary"] = entry.summary;
    type["dimensions"] = dimensions;
    type["keys"] = keys;
    type["schema"] = to_python(entry.schema_properties);
    types.append(type);
  };
  for (const auto& name : two.names()) add(two, name, three.contains(name) ? py::list(py::make_tuple(2, 3)) : py::list(py::make_tuple(2)));
  for (const auto& name : three.names())
    if (!two.contains(name)) add(three, name, py::list(py::make_tuple(3)));
  return types;
}

}  // namespace

void bind_plugins(py::module_& m) {
  m.def(
      "_catalogue",
      [] {
        py::dict d;
        d["field"] = catalogue_data(field_registry<2>(), field_registry<3>());
        d["energy"] = catalogue_data(energy_registry<2>(), energy_registry<3>());
        return d;
      },
      "Every field and energy type with its keys (name, type, unit, default, range, help) and their JSON\n"
      "Schema: what field() and energy() accept, as data (the type stubs are generated from it).");
  m.def("field", &field, py::arg("image"), py::arg("type") = "gvf",
        ("Computes an external field on an Image's grid: a float32 array [z, y, x, D] ([y, x, D] in 2D), the\n"
         "vector at each voxel with its components in (x, y[, z]) order. The keyword options are the\n"
         "experiment file's \"field\" keys. Types (2D and 3D):\n" +
         catalogue(field_registry<2>(), field_registry<3>()))
            .c_str());
  py::class_<PyEnergy>(m, "Energy", "An energy bound to a template: value(q) and propose(q) on positions q (N x D float64, mm).")
      .def("value", [](PyEnergy& e, py::handle q) { return std::visit([&](auto& b) { return b->value(q); }, e.bound); },
           py::arg("q"), "E(q): the term's energy at positions q (N x D float64, one row per template vertex).")
      .def("propose", [](PyEnergy& e, py::handle q) { return std::visit([&](auto& b) { return b->propose(q); }, e.bound); },
           py::arg("q"),
           "Where each vertex would move under this force alone (N x D); vertices it does not govern stay at q.");
  m.def("energy", &energy, py::arg("type"), py::arg("template"), py::arg("image") = py::none(),
        py::arg("field") = py::none(), py::arg("reference") = py::none(),
        ("Binds an energy to a template: 2D an N x 2 float64 contour (in order), 3D a tuple (vertices N x 3\n"
         "float64, faces F x 3 int) of a closed mesh. image: a dsnake.Image for the terms that read one\n"
         "(external, region, ...), with the field computed from the dict `field` (default {'type': 'gvf'}).\n"
         "reference: a dsnake.Image in which the template at its given positions lies on its object (an\n"
         "atlas image), for the terms that learn their appearance there (patch, profile).\n"
         "The keyword options are the experiment file's \"energies\" keys (without weight). Types:\n" +
         catalogue(energy_registry<2>(), energy_registry<3>()))
            .c_str());
}

}  // namespace dsnake::python
