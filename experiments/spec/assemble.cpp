#include "experiments/spec/assemble.h"

#include "experiments/phantoms/phantoms.h"
#include "framework/core/errors.h"
#include "framework/core/json_text.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "remesh/pipeline.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <fstream>
#include <iostream>

namespace dsnake {

namespace {

// Reads {"targets": [[x, y(, z)] | null, ...]} with one entry per template vertex.
template <int D>
std::vector<std::optional<Point<D>>> read_targets(const std::string& path, int num_template_vertices) {
  const nlohmann::json j = parse_json_text(read_input_text(path, "correspondence file"), path);
  JsonReader r(j, path, "");
  const auto& t = r.raw("targets");
  r.finish();
  if (!t.is_array()) r.fail("targets", "expected an array");
  if (int(t.size()) != num_template_vertices)
    r.fail("targets", "expected one target per template vertex (" + std::to_string(num_template_vertices) +
                          "), found " + std::to_string(t.size()));
  std::vector<std::optional<Point<D>>> targets(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    if (t[i].is_null()) continue;
    const std::string where = "targets[" + std::to_string(i) + "]";
    if (!t[i].is_array() || int(t[i].size()) != D) throw InputError(path, where, "expected null or " + std::to_string(D) + " numbers");
    Point<D> p;
    for (int a = 0; a < D; ++a) {
      if (!t[i][a].is_number()) throw InputError(path, where, "expected numbers");
      p[a] = t[i][a].get<double>();
    }
    targets[i] = p;
  }
  return targets;
}

template <int D>
Template<D> read_template_file(const std::string& path) {
  if constexpr (D == 2) return read_contour_template(path);
  else return read_mesh_template(path);
}

// The image (a file or a rendered phantom), then the corruptions in order. Returns the phantom
// (its image moved into `image`: a volume is not copied), whose truth the experiment takes
// unless files override it.
template <int D>
std::optional<Phantom<D>> assemble_image(const ExperimentSpec<D>& spec, Image<D>& image,
                                         std::optional<ImageLayout>& layout) {
  std::optional<Phantom<D>> phantom;
  if (spec.image.phantom) {
    phantom = spec.image.phantom->build();
    image = std::move(phantom->image);
  } else {
    layout.emplace();
    image = read_image<D>(spec.image.file, spec.image.read, &*layout);
  }
  for (size_t i = 0; i < spec.image.corruptions.size(); ++i)
    apply_corruption<D>(image, spec.image.corruptions[i], spec.seed, static_cast<int>(i));
  return phantom;
}

template <int D>
Template<D> assemble_template(const ExperimentSpec<D>& spec) {
  const TemplateSpec<D>& t = spec.tmpl;
  Template<D> tmpl;
  if (t.phantom) {
    tmpl = t.phantom->build();
  } else {
    tmpl = read_template_file<D>(t.file);
    // A template that crosses itself (a figure-eight contour, a mesh through itself) has no
    // inside: refused. A file's template only: the phantoms are simple by construction.
    const int crossings = count_self_intersections<D>({tmpl.positions, tmpl.connectivity});
    if (crossings > 0)
      throw InputError(t.file, "", std::string("the template crosses itself (") + std::to_string(crossings) +
                                       (D == 2 ? " pairs of crossing segments)" : " pairs of intersecting triangles)") +
                                       ": a template must be a simple closed " + (D == 2 ? "curve" : "surface"));
  }
  if (tmpl.num_vertices() == 0) throw InputError(spec.file.path, "template", "empty template");
  for (const auto& [name, id] : t.landmarks) {
    if (id >= tmpl.num_vertices())
      throw InputError(spec.file.path, "template.landmarks." + name,
                       "expected a template vertex id in [0, " + std::to_string(tmpl.num_vertices() - 1) + "]");
    tmpl.landmarks[name] = id;
  }
  return tmpl;
}

// "template.reference_image": read as an image; a problem with it names the experiment file and
// the key, then the image's own message (which names the image file).
template <int D>
Image<D> read_reference_image(const ExperimentSpec<D>& spec) {
  try {
    return read_image<D>(spec.tmpl.reference_image, spec.image.read);
  } catch (const InputError& e) {
    const std::string where = e.where().empty() ? "" : " (" + e.where() + ")";
    throw InputError(spec.file.path, "template.reference_image", e.file() + where + ": " + e.message());
  }
}

// "template.start": a file with the template's vertices (in its order) and its edges or faces,
// whose positions replace the placed template's; a problem names the experiment file and the key,
// then the file's own message.
template <int D>
PointList<D> read_start(const ExperimentSpec<D>& spec, const Template<D>& tmpl) {
  const std::string& path = spec.tmpl.start;
  Template<D> start;
  try {
    start = read_template_file<D>(path);
  } catch (const InputError& e) {
    const std::string where = e.where().empty() ? "" : " (" + e.where() + ")";
    throw InputError(spec.file.path, "template.start", e.file() + where + ": " + e.message());
  }
  auto refuse = [&](const std::string& why) { throw InputError(spec.file.path, "template.start", path + ": " + why); };
  if (start.num_vertices() != tmpl.num_vertices())
    refuse("has " + std::to_string(start.num_vertices()) + " vertices, the template " +
           std::to_string(tmpl.num_vertices()) + ": the start must carry the template's vertices in its order");
  // The same faces, in any order and each from any of its corners (writers reorder them), with
  // the template's orientation.
  auto faces = [](const Connectivity& c) {
    std::vector<Triangle> f = c.triangles();
    for (Triangle& t : f) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    std::sort(f.begin(), f.end());
    return f;
  };
  if (faces(start.connectivity) != faces(tmpl.connectivity))
    refuse("has other faces than the template: the start must keep the template's faces, vertex for vertex");
  // Another method's result may fold where its warp carried thin parts (a deformable peer on a
  // cortical parcel): taken, with a warning; the collision guard blames a move only for the
  // crossings it creates, and leaves these to the forces.
  const int crossings = count_self_intersections<D>({start.positions, start.connectivity});
  if (crossings > 0)
    std::cerr << "warning: " << spec.file.path << ": template.start: " << path << " crosses itself ("
              << crossings << (D == 2 ? " pairs of crossing segments" : " pairs of intersecting triangles")
              << "): the snake starts so, and the collision guard keeps it from crossing more\n";
  return std::move(start.positions);
}

// Ground truth: the phantom's own (its surface moved, its mask as bytes), then explicit files
// override.
template <int D>
GroundTruth<D> assemble_truth(const ExperimentSpec<D>& spec, std::optional<Phantom<D>>&& phantom,
                              const Template<D>& tmpl) {
  GroundTruth<D> truth;
  if (phantom) {
    truth.mask = BinaryMask<D>(phantom->mask);  // a byte per voxel; the phantom's floats go now
    phantom->mask = Image<D>();
    truth.surface = std::move(phantom->surface);
    if (spec.tmpl.phantom) truth.targets = phantom_targets<D>(*spec.image.phantom, *spec.tmpl.phantom, tmpl);
  }
  const GroundTruthSpec& files = spec.truth;
  if (!files.mask.empty()) {
    truth.mask = read_image<D>(files.mask, spec.image.read);
    // A mask without an inside voxel (a wrong label map) would score every result 0 and leave the
    // distances empty without a word.
    if (std::none_of(truth.mask->data().begin(), truth.mask->data().end(), [](uint8_t v) { return v != 0; }))
      throw InputError(files.mask, "", "no voxel is inside (every voxel is 0): a ground-truth mask must hold the object");
  }
  if (!files.surface.empty()) truth.surface = read_shape<D>(files.surface);
  if (!files.correspondence.empty()) truth.targets = read_targets<D>(files.correspondence, tmpl.num_vertices());
  return truth;
}

// Builds the energies, with the checks that need them built: the template's own rules, a
// least-squares form for a global solve, and some energy governing free vertices.
template <int D>
std::vector<WeightedEnergy<D>> assemble_energies(const ExperimentSpec<D>& spec, const Template<D>& tmpl) {
  std::vector<WeightedEnergy<D>> energies;
  bool governs_all = false;
  for (const EnergySpec<D>& e : spec.energies) {
    WeightedEnergy<D> we{e.weight, e.energy.build()};
    try {
      we.energy->check_template(tmpl);
    } catch (const OptionError& error) {
      throw InputError(spec.file.path, e.path + "." + error.key, error.message);
    }
    if (we.energy->needs_reference_image() && spec.tmpl.reference_image.empty())
      throw InputError(spec.file.path, e.path + ".type",
                       "the " + we.energy->type() + " energy needs an atlas image: set template.reference_image");
    if (spec.solver == SolverKind::kGlobal && !we.energy->has_least_squares_form())
      throw InputError(spec.file.path, e.path + ".type",
                       "the " + we.energy->type() + " energy has no least-squares form, so \"solver\": \"global\" cannot use it");
    governs_all |= we.energy->governs() == Governs::kAllVertices;
    energies.push_back(std::move(we));
  }
  if (!governs_all)
    throw InputError(spec.file.path, "energies", "no energy governs free vertices: add \"internal\" or \"external\"");
  return energies;
}

// The placed template's perimeter (2D, mm) or surface area (3D, mm^2).
template <int D>
double boundary_measure(const PointList<D>& q, const Connectivity& c) {
  double m = 0;
  if constexpr (D == 2) {
    for (const auto& [a, b] : c.edges()) m += (q[b] - q[a]).norm();
  } else {
    for (const Triangle& t : c.triangles()) m += 0.5 * (q[t[1]] - q[t[0]]).cross(q[t[2]] - q[t[0]]).norm();
  }
  return m;
}

// A stage's refinement length against the vertex budget (§5.4 bounds edges from below for the
// same reason: an oversized mesh slows every iteration). The vertices a snake of this boundary
// needs when its edges are at most `length`: 2D its perimeter / length; 3D about half its
// triangles (a closed mesh has about twice as many triangles as vertices), each at most the
// equilateral triangle's area sqrt(3) / 4 length^2. Both are lower estimates, so what is
// refused surely exceeds the budget (a snake that grows is stopped by the remeshers, remesher.h).
template <int D>
void check_vertex_budget(const ExperimentSpec<D>& spec, const std::string& stage_path, const RefinementLength& r,
                         double boundary) {
  const double vertices = D == 2 ? boundary / r.length : boundary / (std::sqrt(3.0) / 2 * r.length * r.length);
  const double budget = spec.watchdog.max_vertices;
  if (vertices <= budget) return;
  const double shortest = D == 2 ? boundary / budget : std::sqrt(boundary / (std::sqrt(3.0) / 2 * budget));
  char text[400];
  std::snprintf(text, sizeof text,
                "%.3g mm would need about %.2g vertices for the placed template (%s %.4g %s; watchdog.max_vertices "
                "%d): use at least %.3g mm, or raise watchdog.max_vertices",
                r.length, vertices, D == 2 ? "perimeter" : "area", boundary, D == 2 ? "mm" : "mm^2",
                spec.watchdog.max_vertices, shortest);
  throw InputError(spec.file.path, stage_path + "." + r.key, text);
}

// The phases, each stage checked against the vertex budget for the placed template (`initial`).
template <int D>
std::vector<Phase<D>> assemble_phases(const ExperimentSpec<D>& spec, const Template<D>& tmpl, const PointList<D>& initial) {
  const double boundary = boundary_measure<D>(initial, tmpl.connectivity);
  std::vector<Phase<D>> phases;
  for (size_t p = 0; p < spec.phases.size(); ++p) {
    const PhaseSpec<D>& s = spec.phases[p];
    Phase<D> ph;
    static_cast<PhaseOptions&>(ph) = s;
    // The stages as one pipeline (3D: one pass over a shared editable mesh, same result).
    if (!s.remesh.empty()) {
      std::vector<std::unique_ptr<Remesher<D>>> stages;
      for (size_t k = 0; k < s.remesh.size(); ++k) {
        stages.push_back(s.remesh[k].build());
        if (const auto length = stages.back()->refinement_length())
          check_vertex_budget(spec, "phases[" + std::to_string(p) + "].remesh[" + std::to_string(k) + "]", *length, boundary);
      }
      ph.remesher = std::make_unique<RemeshPipeline<D>>(std::move(stages));
    }
    phases.push_back(std::move(ph));
  }
  return phases;
}

// An oblique image (a rotated direction, image.h) is registered in its grid's frame: the placed
// template, the ground-truth surface and targets are mapped from world into it here, and the
// runner maps results back (runner.cpp). A ground-truth mask must share the image's direction
// (it is re-expressed in the image's frame); a mask whose axes are turned against the image's is
// first resampled onto a grid along the image's axes (resample_along: linear, inside at 0.5), with
// a warning, as a label drawn on another acquisition is compared with the scan's in any viewer.
template <int D>
void express_in_image_frame(Experiment<D>& ex, const GroundTruthSpec& files) {
  const Grid<D>& g = ex.image.grid();
  if (g.axis_aligned() && (!ex.truth.mask || ex.truth.mask->grid().axis_aligned())) return;
  if (ex.truth.mask) {
    if ((ex.truth.mask->grid().direction - g.direction).cwiseAbs().maxCoeff() > 1e-6) {
      ex.truth.mask = resample_along(*ex.truth.mask, g.direction);
      std::cerr << "warning: " << files.mask
                << ": the mask's axes are turned against the image's: resampled along the image's axes for the "
                   "metrics (linear interpolation, inside at 0.5)\n";
    }
    Grid<D> m = ex.truth.mask->grid();
    m.origin = g.to_frame(m.origin);
    m.direction.setIdentity();
    ex.truth.mask = BinaryMask<D>(m, std::move(ex.truth.mask->data()));
  }
  for (auto& p : ex.initial) p = g.to_frame(p);
  if (ex.truth.surface)
    for (auto& p : ex.truth.surface->positions) p = g.to_frame(p);
  for (auto& t : ex.truth.targets)
    if (t) *t = g.to_frame(*t);
}

}  // namespace

namespace {

// The first axis along which p lies more than the image's extent beyond its border, in
// continuous voxel indices (or is not finite); -1 when it lies near the image.
template <int D>
int axis_beyond_image(const Grid<D>& g, const Point<D>& p) {
  const Point<D> c = g.to_continuous_index(p);
  for (int a = 0; a < D; ++a)
    if (!std::isfinite(c[a]) || c[a] < -double(g.size[a]) || c[a] > 2.0 * g.size[a]) return a;
  return -1;
}

}  // namespace

// The placed template must lie near the image (a template scaled by 1e200 ran, diverged and
// crashed instead of being refused): every vertex within one image extent of the image's box,
// in continuous voxel indices.
template <int D>
std::string outside_the_image(const PointList<D>& points, const Grid<D>& grid) {
  for (size_t v = 0; v < points.size(); ++v)
    if (const int a = axis_beyond_image(grid, points[v]); a >= 0)
      return "lies outside the image: vertex " + std::to_string(v) +
             " is more than the image's extent beyond its border along axis " + std::to_string(a);
  return "";
}

template <int D>
void check_placement(const Experiment<D>& ex, const std::string& file, bool from_start) {
  const Grid<D>& g = ex.image.grid();
  const std::string key = from_start ? "template.start" : "template.transform";
  const std::string noun = from_start ? "the start " : "the placed template ";
  if (const std::string what = outside_the_image<D>(ex.initial, g); !what.empty()) throw InputError(file, key, noun + what);
  if (const std::string what = smaller_than_a_voxel<D>(ex.initial, g); !what.empty()) throw InputError(file, key, noun + what);
}

template <int D>
std::string smaller_than_a_voxel(const PointList<D>& points, const Grid<D>& grid) {
  Point<D> lo = Point<D>::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Point<D>& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double extent = points.empty() ? 0 : (hi - lo).norm(), voxel = grid.spacing.minCoeff();
  if (extent >= voxel) return "";
  char what[160];
  std::snprintf(what, sizeof what, "spans %.3g mm, less than a voxel (%.3g mm): scale it to the object's size", extent,
                voxel);
  return what;
}

template std::string smaller_than_a_voxel<2>(const PointList<2>&, const Grid<2>&);
template std::string smaller_than_a_voxel<3>(const PointList<3>&, const Grid<3>&);
template std::string outside_the_image<2>(const PointList<2>&, const Grid<2>&);
template std::string outside_the_image<3>(const PointList<3>&, const Grid<3>&);

// The ground truth must lie near the image too (a phantom whose object was made 1e300 mm wide
// ran and crashed in the metrics, whose distances overflow): its surface's vertices, its targets
// and a mask file's inside voxels (a mask elsewhere in the world scored every result 0 without a
// word) within one image extent of the image's box, as the template's. The mask is in the
// image's frame by now (express_in_image_frame), its direction the identity.
template <int D>
void check_truth_placement(const Experiment<D>& ex, const ExperimentSpec<D>& spec) {
  auto check = [&](const Point<D>& p, const std::string& file, const std::string& key, const std::string& what) {
    if (const int a = axis_beyond_image(ex.image.grid(), p); a >= 0)
      throw InputError(file, key, what + " lies outside the image: more than the image's extent beyond its border along axis " +
                                      std::to_string(a));
  };
  if (ex.truth.surface) {
    const bool from_file = !spec.truth.surface.empty();
    const std::string file = from_file ? spec.truth.surface : spec.file.path;
    const std::string key = from_file ? "" : "image";
    for (size_t v = 0; v < ex.truth.surface->positions.size(); ++v)
      check(ex.truth.surface->positions[v], file, from_file ? "vertex " + std::to_string(v) : key,
            from_file ? "the ground-truth surface" : "the phantom's object (its true surface)");
  }
  for (size_t t = 0; t < ex.truth.targets.size(); ++t)
    if (ex.truth.targets[t])
      check(*ex.truth.targets[t], spec.truth.correspondence.empty() ? spec.file.path : spec.truth.correspondence,
            "template id " + std::to_string(t), "the ground-truth counterpart");
  if (ex.truth.mask && !spec.truth.mask.empty()) {
    const BinaryMask<D>& m = *ex.truth.mask;
    for (int64_t l = 0; l < m.num_voxels(); ++l) {
      if (!m[l]) continue;
      const Point<D> p = m.grid().to_physical(m.grid().index(l));
      const int a = axis_beyond_image(ex.image.grid(), p);
      if (a < 0) continue;
      const Point<D> world = ex.image.grid().to_world(p);
      std::string at;
      for (int k = 0; k < D; ++k) {
        char c[32];
        std::snprintf(c, sizeof c, "%s%.6g", k ? ", " : "", world[k]);
        at += c;
      }
      throw InputError(spec.truth.mask, "ground_truth.mask",
                       "the mask's inside voxel at (" + at + ") mm lies outside the image: more than the image's "
                       "extent beyond its border along axis " + std::to_string(a));
    }
  }
}

template <int D>
Experiment<D> assemble(const ExperimentSpec<D>& spec) {
  Experiment<D> ex;
  static_cast<RunSettings&>(ex) = spec;  // the run keys and run-level sections, whole
  ex.file = spec.file;
  std::optional<Phantom<D>> phantom = assemble_image(spec, ex.image, ex.image_layout);
  ex.image_is_file_as_read = !spec.image.phantom && spec.image.corruptions.empty();
  ex.tmpl = assemble_template(spec);
  const PlacementSpec<D>& t = spec.tmpl.transform;
  ex.initial = place<D>(ex.tmpl.positions, t.scale, t.rotation_deg, t.translation);
  if (!spec.tmpl.reference_image.empty()) ex.reference_image = read_reference_image(spec);
  // The pre-alignment in world coordinates, after the placement (template_init.h).
  if (spec.tmpl.init)
    ex.init = initialize_template<D>(*spec.tmpl.init, ex.tmpl, ex.image, ex.initial, spec.file.path,
                                     ex.reference_image ? &*ex.reference_image : nullptr);
  if (!spec.tmpl.start.empty()) ex.initial = read_start(spec, ex.tmpl);
  ex.truth = assemble_truth(spec, std::move(phantom), ex.tmpl);
  express_in_image_frame(ex, spec.truth);
  check_placement(ex, spec.file.path, !spec.tmpl.start.empty());
  check_truth_placement(ex, spec);
  ex.field = build_field(spec.field);
  try {  // the checks a field can make on the image's grid, so that `validate` reports them too
    ex.field->check_grid(ex.image.grid());
  } catch (const InputError& e) {
    if (!e.file().empty()) throw;
    throw InputError(spec.file.path, e.where(), e.message());
  }
  ex.field_region = spec.field.region;
  ex.energies = assemble_energies(spec, ex.tmpl);
  ex.phases = assemble_phases(spec, ex.tmpl, ex.initial);
  for (size_t p = 0; p < spec.phases.size(); ++p)
    ex.phase_names.push_back(spec.phases[p].name.empty() ? "#" + std::to_string(p + 1) : spec.phases[p].name);
  return ex;
}

template <int D>
Experiment<D> make_experiment(const ExperimentFile& file) {
  return assemble(read_experiment_spec<D>(file));
}

template Experiment<2> assemble<2>(const ExperimentSpec<2>&);
template Experiment<3> assemble<3>(const ExperimentSpec<3>&);
template Experiment<2> make_experiment<2>(const ExperimentFile&);
template Experiment<3> make_experiment<3>(const ExperimentFile&);

}  // namespace dsnake
