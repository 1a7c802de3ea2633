#include "experiments/spec/experiment_spec.h"

#include "energies/registry.h"
#include "framework/core/errors.h"
#include "remesh/registry.h"

#include <cmath>
#include <filesystem>

namespace dsnake {

namespace fs = std::filesystem;

namespace {

std::string resolve(const ExperimentFile& f, const std::string& p) {
  if (p.empty() || fs::path(p).is_absolute() || f.base_dir.empty()) return p;
  return (fs::path(f.base_dir) / p).string();
}

// "file": exactly one of a file and a phantom; a phantom's kind and its family's keys are read
// into its options here (experiments/phantoms/phantoms.h).
template <class Product>
std::optional<PhantomSpec<Product>> read_source(JsonReader& r, const ExperimentFile& f, std::string& file,
                                                const PhantomRegistry<Product>& phantoms) {
  if (r.has("file") == r.has("phantom")) r.fail("", "give exactly one of \"file\" and \"phantom\"");
  if (r.has("file")) {
    r.read("file", file);
    // (An empty path would reach the readers as a file without a name, refused without one.)
    if (file.empty()) r.fail("file", "must be a non-empty file name");
    file = resolve(f, file);
    return std::nullopt;
  }
  return phantoms.read(r);
}

// A section object read into its options, every key checked.
template <class O>
void read_section(JsonReader& top, const char* key, O& options) {
  JsonReader r = top.child(key);
  read_options(r, options);
  r.finish();
}

template <int D>
ImageSpec<D> read_image_section(JsonReader& top, const ExperimentFile& f) {
  ImageSpec<D> spec;
  JsonReader r = top.child("image");
  read_options(r, spec.read);
  spec.phantom = read_source(r, f, spec.file, image_phantoms<D>());
  r.finish();
  if (top.has("corruption")) {
    const auto& list = top.raw("corruption");
    if (!list.is_array()) top.fail("corruption", "expected an array");
    for (size_t i = 0; i < list.size(); ++i) {
      JsonReader c(list[i], f.path, "corruption[" + std::to_string(i) + "]");
      spec.corruptions.push_back(read_corruption(c));
    }
  }
  return spec;
}

// "template.init": a required type, the keys of that type, points of D numbers; the mask's path
// resolved against the experiment's folder.
template <int D>
TemplateInitOptions read_init(JsonReader r, const ExperimentFile& f) {
  if (!r.has("type")) r.fail("type", "is required (\"moments\", \"landmarks\" or \"image\")");
  TemplateInitOptions init;
  read_options(r, init);
  r.finish();
  for (const auto& [name, p] : init.points)
    r.expect(int(p.size()) == D, "points." + name, "expected " + std::to_string(D) + " numbers");
  init.mask = resolve(f, init.mask);
  return init;
}

template <int D>
TemplateSpec<D> read_template_section(JsonReader& top, const ExperimentFile& f, const ImageReadOptions& read) {
  TemplateSpec<D> spec;
  JsonReader r = top.child("template");
  spec.phantom = read_source(r, f, spec.file, template_phantoms<D>());
  read_options(r, spec);
  if (r.has("reference_image")) r.expect(!spec.reference_image.empty(), "reference_image", "expected an image file");
  spec.reference_image = resolve(f, spec.reference_image);
  if (r.has("transform")) read_section(r, "transform", spec.transform);
  if (r.has("init")) spec.init = read_init<D>(r.child("init"), f);
  if (spec.init && spec.init->type == TemplateInitType::kImage && spec.reference_image.empty())
    r.fail("init.type", "\"image\" needs template.reference_image (the atlas the template's file positions lie on)");
  if (spec.init) spec.init->mask_read = read;
  if (r.has("start")) {
    r.expect(!spec.start.empty(), "start", "expected a contour or mesh file");
    r.expect(!r.has("transform") && !r.has("init"), "start",
             "gives the start itself: template.transform and template.init would be ignored, so give one or the other");
  }
  spec.start = resolve(f, spec.start);
  r.finish();
  return spec;
}

GroundTruthSpec read_truth_section(JsonReader r, const ExperimentFile& f) {
  GroundTruthSpec t;
  read_options(r, t);
  r.finish();
  t.mask = resolve(f, t.mask);
  t.surface = resolve(f, t.surface);
  t.correspondence = resolve(f, t.correspondence);
  return t;
}

template <int D>
std::vector<EnergySpec<D>> read_energies_section(JsonReader& top, const ExperimentFile& f, SolverKind solver) {
  const auto& list = top.raw("energies");
  if (!list.is_array() || list.empty()) top.fail("energies", "expected a non-empty array of energies");
  std::vector<EnergySpec<D>> energies;
  for (size_t i = 0; i < list.size(); ++i) {
    EnergySpec<D> e;
    e.path = "energies[" + std::to_string(i) + "]";
    JsonReader r(list[i], f.path, e.path);
    read_options(r, static_cast<EnergyWeight&>(e));
    e.energy = energy_registry<D>().read(r);
    energies.push_back(std::move(e));
  }
  return energies;
}

template <int D>
PhaseSpec<D> read_phase(JsonReader& r, size_t num_energies) {
  PhaseSpec<D> ph;
  read_options(r, ph);
  if (r.has("weights")) {
    r.expect(ph.weights.size() == num_energies, "weights",
             "expected one weight per energy (" + std::to_string(num_energies) + ")");
    bool any = false;
    for (double w : ph.weights) {
      r.expect(w >= 0 && std::isfinite(w), "weights", "every weight must be >= 0");
      any |= w > 0;
    }
    r.expect(any, "weights", "at least one weight must be > 0");
  }
  if (r.has("remesh")) {
    const auto& stages = r.raw("remesh");
    if (!stages.is_array()) r.fail("remesh", "expected an array of remeshing stages");
    for (size_t k = 0; k < stages.size(); ++k) {
      JsonReader s(stages[k], r.file(), r.path_of("remesh[" + std::to_string(k) + "]"));
      ph.remesh.push_back(remesher_registry<D>().read(s));
    }
  }
  r.finish();
  return ph;
}

template <int D>
std::vector<PhaseSpec<D>> read_phases_section(JsonReader& top, const ExperimentFile& f, size_t num_energies) {
  const auto& list = top.raw("phases");
  if (!list.is_array() || list.empty()) top.fail("phases", "expected a non-empty array of phases");
  std::vector<PhaseSpec<D>> phases;
  for (size_t i = 0; i < list.size(); ++i) {
    JsonReader r(list[i], f.path, "phases[" + std::to_string(i) + "]");
    phases.push_back(read_phase<D>(r, num_energies));
  }
  return phases;
}

// The run keys, "collision_guard", "global": the run's identity and how it minimises.
template <int D>
void read_run_keys(JsonReader& top, ExperimentSpec<D>& spec) {
  spec.dimension = D;
  read_options(top, static_cast<RunKeys&>(spec));
  if (spec.dimension != D) top.fail("dimension", "internal mismatch");
  if (top.has("collision_guard")) read_section(top, "collision_guard", spec.collision_guard);
  if (top.has("global")) {
    // The "global" object: Ceres' options and the external term's potential.
    JsonReader g = top.child("global");
    read_options(g, spec.global);
    spec.potential = read_options<PotentialOptions>(g);
    g.finish();
  } else {
    // Every run, snake or global solve, values its external term with a potential (the default
    // one without a "global" object), so that `total` is one energy for every field and solver.
    spec.potential = PotentialOptions{};
  }
}

}  // namespace

template <int D>
ExperimentSpec<D> read_experiment_spec(const ExperimentFile& file) {
  DSNAKE_ASSERT(file.dimension == D, "dimension matches");
  ExperimentSpec<D> spec;
  spec.file = file;
  JsonReader top(file.document, file.path, "");
  read_run_keys(top, spec);
  spec.image = read_image_section<D>(top, file);
  spec.tmpl = read_template_section<D>(top, file, spec.image.read);
  if (top.has("ground_truth")) spec.truth = read_truth_section(top.child("ground_truth"), file);
  {
    JsonReader r = top.child("field");
    spec.field = read_field_spec<D>(r);
  }
  spec.energies = read_energies_section<D>(top, file, spec.solver);
  spec.phases = read_phases_section<D>(top, file, spec.energies.size());
  spec.success = SuccessCriteria::defaults();
  if (top.has("success")) {
    spec.success = SuccessCriteria{};
    read_section(top, "success", spec.success);
  }
  if (top.has("output")) read_section(top, "output", spec.output);
  if (top.has("metrics")) read_section(top, "metrics", spec.metrics);
  if (top.has("watchdog")) read_section(top, "watchdog", spec.watchdog);
  top.finish();
  return spec;
}

template ExperimentSpec<2> read_experiment_spec<2>(const ExperimentFile&);
template ExperimentSpec<3> read_experiment_spec<3>(const ExperimentFile&);

}  // namespace dsnake
