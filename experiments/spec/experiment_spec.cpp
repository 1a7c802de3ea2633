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

// "file": exactly one of a file and a phantom; the phantom keeps its object minus `own_keys`.
std::optional<PhantomSource> read_source(JsonReader& r, const ExperimentFile& f, std::string& file,
                                         std::initializer_list<const char*> own_keys) {
  if (r.has("file") == r.has("phantom")) r.fail("", "give exactly one of \"file\" and \"phantom\"");
  if (r.has("file")) {
    r.read("file", file);
    file = resolve(f, file);
    return std::nullopt;
  }
  PhantomSource source{r.object(), r.file(), r.path()};
  for (const char* k : own_keys) source.object.erase(k);
  for (auto it = source.object.begin(); it != source.object.end(); ++it) r.skip(it.key());  // the phantom reads them
  return source;
}

template <int D>
ImageSpec<D> read_image_section(JsonReader& top, const ExperimentFile& f) {
  ImageSpec<D> spec;
  JsonReader r = top.child("image");
  read_options(r, spec.read);
  spec.phantom = read_source(r, f, spec.file, {"nifti_transform"});
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

template <int D>
PlacementSpec<D> read_placement(JsonReader t) {
  PlacementSpec<D> p;
  t.read("scale", p.scale);
  t.expect(p.scale > 0, "scale", "must be > 0");
  t.read("rotation_deg", p.rotation_deg);
  t.expect(int(p.rotation_deg.size()) <= (D == 2 ? 1 : 3), "rotation_deg",
           D == 2 ? "expected one angle" : "expected up to three angles (x, y, z)");
  t.read<D>("translation", p.translation);
  t.finish();
  return p;
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
  spec.phantom = read_source(r, f, spec.file, {"landmarks", "transform", "reference_image", "init"});
  if (r.has("landmarks")) {
    const auto& lm = r.raw("landmarks");
    if (!lm.is_object()) r.fail("landmarks", "expected an object {\"name\": vertex id}");
    for (auto it = lm.begin(); it != lm.end(); ++it) {
      if (!it->is_number_integer() || it->get<int64_t>() < 0 || it->get<int64_t>() > 2000000000)
        r.fail("landmarks." + it.key(), "expected a template vertex id (an integer >= 0)");
      spec.landmarks[it.key()] = it->get<int>();
    }
  }
  if (r.has("transform")) spec.transform = read_placement<D>(r.child("transform"));
  r.read("reference_image", spec.reference_image);
  if (r.has("reference_image")) r.expect(!spec.reference_image.empty(), "reference_image", "expected an image file");
  spec.reference_image = resolve(f, spec.reference_image);
  if (r.has("init")) spec.init = read_init<D>(r.child("init"), f);
  if (spec.init && spec.init->type == TemplateInitType::kImage && spec.reference_image.empty())
    r.fail("init.type", "\"image\" needs template.reference_image (the atlas the template's file positions lie on)");
  if (spec.init) spec.init->mask_read = read;
  r.finish();
  return spec;
}

GroundTruthSpec read_truth_section(JsonReader r, const ExperimentFile& f) {
  GroundTruthSpec t;
  r.read("mask", t.mask);
  r.read("surface", t.surface);
  r.read("correspondence", t.correspondence);
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
    r.read("weight", e.weight);
    r.expect(e.weight > 0, "weight", "must be > 0");
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

// "seed", "solver", "collision_guard", "global": the run's identity and how it minimises.
template <int D>
void read_run_keys(JsonReader& top, ExperimentSpec<D>& spec) {
  int dimension = D;
  top.read("dimension", dimension);
  if (dimension != D) top.fail("dimension", "internal mismatch");
  top.read("name", spec.name);
  top.read("description", spec.description);
  double seed = 0;
  top.read("seed", seed);
  top.expect(seed >= 0 && seed == std::floor(seed) && seed < 9.007e15, "seed", "must be a non-negative integer");
  spec.seed = static_cast<uint64_t>(seed);
  if (top.has("solver")) {
    std::string solver;
    top.read("solver", solver);
    const auto kind = enum_from_name<SolverKind>(solver);
    if (!kind) top.fail("solver", "must be " + enum_choices<SolverKind>());
    spec.solver = *kind;
  }
  if (top.has("collision_guard")) {
    JsonReader g = top.child("collision_guard");
    read_options(g, spec.collision_guard);
    g.finish();
  }
  if (top.has("global")) {
    // The "global" object: Ceres' options and the external term's potential, for a
    // global solve or for a snake run whose energies are reported with the same potential.
    JsonReader g = top.child("global");
    read_options(g, spec.global);
    spec.potential = read_options<PotentialOptions>(g);
    g.finish();
  } else if (spec.solver == SolverKind::kGlobal) {
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
    JsonReader r = top.child("success");
    read_options(r, spec.success);
    r.finish();
  }
  if (top.has("output")) {
    JsonReader r = top.child("output");
    read_options(r, spec.output);
    r.finish();
  }
  if (top.has("metrics")) {
    JsonReader r = top.child("metrics");
    read_options(r, spec.metrics);
    r.finish();
  }
  if (top.has("watchdog")) {
    JsonReader r = top.child("watchdog");
    read_options(r, spec.watchdog);
    r.finish();
  }
  top.finish();
  return spec;
}

template ExperimentSpec<2> read_experiment_spec<2>(const ExperimentFile&);
template ExperimentSpec<3> read_experiment_spec<3>(const ExperimentFile&);

}  // namespace dsnake
