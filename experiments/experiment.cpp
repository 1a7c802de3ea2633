#include "experiments/experiment.h"

#include "energies/registry.h"
#include "experiments/builtin.h"
#include "experiments/corruption.h"
#include "experiments/phantoms.h"
#include "fields/registry.h"
#include "fields/smooth_potential.h"
#include "framework/errors.h"
#include "framework/image_io.h"
#include "framework/json_reader.h"
#include "framework/mesh_io.h"
#include "remesh/pass.h"
#include "remesh/registry.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake {

namespace fs = std::filesystem;

namespace {

// Strips nlohmann's "[json.exception.x.y] " prefix from a message.
std::string clean_json_message(const std::string& what) {
  const auto p = what.find("] ");
  return p == std::string::npos ? what : what.substr(p + 2);
}

// Applies one "a.b[2].c=value" override to the document.
void apply_override(nlohmann::json& doc, const std::string& assignment, const std::string& file) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError("", "--set " + assignment, "expected key.path=value");
  const std::string path = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  nlohmann::json value;
  try {
    value = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception&) {
    value = text;  // a bare word is a string
  }
  nlohmann::json* node = &doc;
  std::string token;
  auto descend = [&](const std::string& key, bool is_index) {
    if (is_index) {
      if (!node->is_array()) throw InputError(file, path, "\"" + key + "\" indexes something that is not an array");
      const size_t i = std::stoul(key);
      if (i >= node->size()) throw InputError(file, path, "index " + key + " is out of range");
      node = &(*node)[i];
    } else {
      if (node->is_null()) *node = nlohmann::json::object();  // "output.figures=false" creates "output"
      if (!node->is_object()) throw InputError(file, path, "\"" + key + "\" names a key of something that is not an object");
      node = &(*node)[key];
    }
  };
  size_t i = 0;
  while (i < path.size()) {
    if (path[i] == '.') { ++i; continue; }
    if (path[i] == '[') {
      const auto close = path.find(']', i);
      if (close == std::string::npos) throw InputError("", "--set " + path, "unclosed '['");
      descend(path.substr(i + 1, close - i - 1), true);
      i = close + 1;
      continue;
    }
    const auto end = path.find_first_of(".[", i);
    token = path.substr(i, end == std::string::npos ? std::string::npos : end - i);
    const bool numeric = !token.empty() && token.find_first_not_of("0123456789") == std::string::npos;
    descend(token, numeric && node->is_array());
    i = end == std::string::npos ? path.size() : end;
  }
  *node = value;
}

ExperimentFile finish_file(ExperimentFile f, const std::vector<std::string>& overrides) {
  for (const auto& o : overrides) apply_override(f.document, o, f.path);
  if (!f.document.is_object()) throw InputError(f.path, "(top level)", "expected a JSON object");
  const auto it = f.document.find("dimension");
  if (it == f.document.end()) throw InputError(f.path, "dimension", "is required (2 or 3)");
  if (!it->is_number_integer() || (it->get<int>() != 2 && it->get<int>() != 3))
    throw InputError(f.path, "dimension", "must be 2 or 3, found " + it->dump());
  f.dimension = it->get<int>();
  return f;
}

std::string resolve(const ExperimentFile& f, const std::string& p) {
  if (p.empty() || fs::path(p).is_absolute() || f.base_dir.empty()) return p;
  return (fs::path(f.base_dir) / p).string();
}

// Reads {"targets": [[x, y(, z)] | null, ...]} with one entry per template vertex.
template <int D>
std::vector<std::optional<Point<D>>> read_targets(const std::string& path, int num_template_vertices) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open the correspondence file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, "", clean_json_message(e.what()));
  }
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

void read_success(JsonReader r, SuccessCriteria& s) {
  auto opt = [&](const char* key, std::optional<double>& v) {
    if (!r.has(key)) return;
    double x = 0;
    r.read(key, x);
    v = x;
  };
  opt("mean_surface_distance", s.mean_surface_distance);
  opt("hausdorff95", s.hausdorff95);
  opt("hausdorff", s.hausdorff);
  opt("dice", s.dice);
  opt("correspondence_error_mean", s.correspondence_error_mean);
  opt("correspondence_error_max", s.correspondence_error_max);
  if (r.has("self_intersections")) {
    int x = 0;
    r.read("self_intersections", x);
    s.self_intersections = x;
  }
  r.finish();
}

}  // namespace

bool SuccessCriteria::met(const Metrics& m) const {
  auto at_most = [this](const std::optional<double>& limit, const std::optional<double>& v) {
    return !limit || (v ? *v <= *limit : skip_null_metrics);
  };
  return at_most(mean_surface_distance, m.mean_surface_distance) && at_most(hausdorff95, m.hausdorff95) &&
         at_most(hausdorff, m.hausdorff) && (!dice || (m.dice ? *m.dice >= *dice : skip_null_metrics)) &&
         at_most(correspondence_error_mean, m.correspondence_error_mean) &&
         at_most(correspondence_error_max, m.correspondence_error_max) &&
         (!self_intersections || m.self_intersections <= *self_intersections);
}

SuccessCriteria SuccessCriteria::defaults() {
  SuccessCriteria s;
  s.mean_surface_distance = 1.0;
  s.hausdorff95 = 2.0;
  s.correspondence_error_max = 2.0;
  s.dice = 0.9;
  s.self_intersections = 0;
  s.skip_null_metrics = true;
  return s;
}

ExperimentFile load_experiment_file(const std::string& path, const std::vector<std::string>& overrides) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", fs::exists(path) ? "cannot read the experiment file" : "no such experiment file");
  ExperimentFile f;
  f.path = path;
  f.base_dir = fs::path(path).parent_path().string();
  try {
    f.document = nlohmann::json::parse(in, nullptr, true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path, "", "JSON syntax error: " + clean_json_message(e.what()));
  }
  return finish_file(std::move(f), overrides);
}

ExperimentFile builtin_experiment(const std::string& name, const std::vector<std::string>& overrides) {
  ExperimentFile f;
  f.path = "builtin:" + name;
  f.document = nlohmann::json::parse(builtin_experiment_text(name));
  return finish_file(std::move(f), overrides);
}

// The "global" object: Ceres' options and the external term's potential (issue 7). Present for
// a global solve, or for a snake run whose energies should be reported with the same potential.
void read_global(JsonReader r, GlobalSolverOptions& g, std::optional<PotentialOptions>& potential) {
  r.read("linear_solver", g.linear_solver);
  r.expect(g.linear_solver == "sparse_normal_cholesky" || g.linear_solver == "sparse_schur" ||
               g.linear_solver == "iterative_schur" || g.linear_solver == "cgnr" || g.linear_solver == "dense_qr",
           "linear_solver",
           "must be \"sparse_normal_cholesky\", \"sparse_schur\", \"iterative_schur\", \"cgnr\" or \"dense_qr\"");
  r.read("max_iterations", g.max_iterations);
  r.expect(g.max_iterations >= 1 && g.max_iterations <= 1000000, "max_iterations", "must be in [1, 1000000]");
  r.read("initial_trust_region_radius", g.initial_trust_region_radius);
  r.read("max_trust_region_radius", g.max_trust_region_radius);
  r.expect(g.initial_trust_region_radius > 0, "initial_trust_region_radius", "must be > 0");
  r.expect(g.max_trust_region_radius >= g.initial_trust_region_radius, "max_trust_region_radius",
           "must be >= initial_trust_region_radius");
  r.read("function_tolerance", g.function_tolerance);
  r.expect(g.function_tolerance >= 0, "function_tolerance", "must be >= 0");
  r.read("gradient_tolerance", g.gradient_tolerance);
  r.expect(g.gradient_tolerance >= 0, "gradient_tolerance", "must be >= 0");
  r.read("parameter_tolerance", g.parameter_tolerance);
  r.expect(g.parameter_tolerance >= 0, "parameter_tolerance", "must be >= 0");
  r.read("threads", g.threads);
  r.expect(g.threads >= 1 && g.threads <= 256, "threads", "must be in [1, 256]");
  r.read("remesh_rounds", g.remesh_rounds);
  r.expect(g.remesh_rounds >= 0 && g.remesh_rounds <= 1000, "remesh_rounds", "must be in [0, 1000]");
  potential = read_options<PotentialOptions>(r);
  r.finish();
}

template <int D>
Experiment<D> build_experiment(const ExperimentFile& file) {
  DSNAKE_ASSERT(file.dimension == D, "dimension matches");
  Experiment<D> ex;
  ex.file = file;
  const std::string& fname = file.path;
  JsonReader top(file.document, fname, "");
  int dimension = D;
  top.read("dimension", dimension);
  top.read("name", ex.name);
  std::string description;
  top.read("description", description);
  double seed = 0;
  top.read("seed", seed);
  top.expect(seed >= 0 && seed == std::floor(seed) && seed < 9.007e15, "seed", "must be a non-negative integer");
  ex.seed = static_cast<uint64_t>(seed);
  top.read("solver", ex.solver);
  top.expect(ex.solver == "snake" || ex.solver == "global", "solver", "must be \"snake\" or \"global\"");
  if (top.has("global")) read_global(top.child("global"), ex.global, ex.potential);
  else if (ex.solver == "global") ex.potential = PotentialOptions{};

  // The image: a file or a phantom, then corruptions in order.
  std::optional<Phantom<D>> phantom;
  {
    JsonReader r = top.child("image");
    if (r.has("file") == r.has("phantom")) r.fail("", "give exactly one of \"file\" and \"phantom\"");
    if (r.has("file")) {
      std::string p;
      r.read("file", p);
      ex.image = read_image<D>(resolve(file, p));
    } else {
      phantom = make_phantom<D>(r);
      ex.image = phantom->image;
    }
    r.finish();
  }
  if (top.has("corruption")) {
    const auto& list = top.raw("corruption");
    if (!list.is_array()) top.fail("corruption", "expected an array");
    for (size_t i = 0; i < list.size(); ++i) {
      JsonReader r(list[i], fname, "corruption[" + std::to_string(i) + "]");
      apply_corruption<D>(ex.image, r, ex.seed, static_cast<int>(i));
      r.finish();
    }
  }

  // The template and its placement.
  nlohmann::json template_spec;
  {
    JsonReader r = top.child("template");
    template_spec = r.object();
    if (r.has("file") == r.has("phantom")) r.fail("", "give exactly one of \"file\" and \"phantom\"");
    if (r.has("file")) {
      std::string p;
      r.read("file", p);
      ex.tmpl = read_template_file<D>(resolve(file, p));
    } else {
      ex.tmpl = make_template_phantom<D>(r);
    }
    if (ex.tmpl.num_vertices() == 0) r.fail("", "empty template");
    if (r.has("landmarks")) {
      const auto& lm = r.raw("landmarks");
      if (!lm.is_object()) r.fail("landmarks", "expected an object {\"name\": vertex id}");
      for (auto it = lm.begin(); it != lm.end(); ++it) {
        if (!it->is_number_integer() || it->get<int>() < 0 || it->get<int>() >= ex.tmpl.num_vertices())
          r.fail("landmarks." + it.key(), "expected a template vertex id in [0, " +
                                              std::to_string(ex.tmpl.num_vertices() - 1) + "]");
        ex.tmpl.landmarks[it.key()] = it->get<int>();
      }
    }
    double scale = 1.0;
    std::vector<double> rotation;
    Point<D> translation = Point<D>::Zero();
    if (r.has("transform")) {
      JsonReader t = r.child("transform");
      t.read("scale", scale);
      t.expect(scale > 0, "scale", "must be > 0");
      t.read("rotation_deg", rotation);
      t.expect(int(rotation.size()) <= (D == 2 ? 1 : 3), "rotation_deg",
               D == 2 ? "expected one angle" : "expected up to three angles (x, y, z)");
      t.read<D>("translation", translation);
      t.finish();
    }
    r.finish();
    ex.initial = place<D>(ex.tmpl.positions, scale, rotation, translation);
  }

  // Ground truth: the phantom's own, then explicit files override.
  if (phantom) {
    ex.truth.mask = phantom->mask;
    ex.truth.surface = phantom->surface;
    ex.truth.targets = phantom_targets<D>(file.document["image"], template_spec, ex.tmpl);
  }
  if (top.has("ground_truth")) {
    JsonReader r = top.child("ground_truth");
    std::string p;
    if (r.has("mask")) {
      r.read("mask", p);
      ex.truth.mask = read_image<D>(resolve(file, p));
    }
    if (r.has("surface")) {
      r.read("surface", p);
      ex.truth.surface = read_shape<D>(resolve(file, p));
    }
    if (r.has("correspondence")) {
      r.read("correspondence", p);
      ex.truth.targets = read_targets<D>(resolve(file, p), ex.tmpl.num_vertices());
    }
    r.finish();
  }

  // Field, energies, phases.
  {
    JsonReader r = top.child("field");
    ex.field = build_field<D>(read_field_spec<D>(r));  // "cache" (--field-cache) and the field
  }
  {
    const auto& list = top.raw("energies");
    if (!list.is_array() || list.empty()) top.fail("energies", "expected a non-empty array of energies");
    bool governs_all = false;
    for (size_t i = 0; i < list.size(); ++i) {
      JsonReader r(list[i], fname, "energies[" + std::to_string(i) + "]");
      WeightedEnergy<D> we;
      r.read("weight", we.weight);
      r.expect(we.weight > 0, "weight", "must be > 0");
      we.energy = energy_registry<D>().create(r);
      if (ex.solver == "global" && !we.energy->has_least_squares_form())
        r.fail("type", "the " + we.energy->type() + " energy has no least-squares form, so \"solver\": \"global\" cannot use it");
      governs_all |= we.energy->governs() == Governs::kAllVertices;
      ex.energies.push_back(std::move(we));
    }
    if (!governs_all)
      top.fail("energies", "no energy governs free vertices: add \"internal\" or \"external\"");
  }
  {
    const auto& list = top.raw("phases");
    if (!list.is_array() || list.empty()) top.fail("phases", "expected a non-empty array of phases");
    for (size_t i = 0; i < list.size(); ++i) {
      JsonReader r(list[i], fname, "phases[" + std::to_string(i) + "]");
      Phase<D> ph;
      std::string name;
      r.read("name", name);
      r.read("iterations", ph.iterations);
      r.read("tolerance", ph.tolerance);
      r.read("every", ph.every);
      r.expect(ph.iterations >= 0 && ph.iterations <= 10000000, "iterations", "must be in [0, 10000000]");
      r.expect(ph.tolerance >= 0, "tolerance", "must be >= 0");
      r.expect(ph.every >= 1, "every", "must be >= 1");
      if (r.has("weights")) {
        r.read("weights", ph.weights);
        r.expect(ph.weights.size() == ex.energies.size(), "weights",
                 "expected one weight per energy (" + std::to_string(ex.energies.size()) + ")");
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
          JsonReader s(stages[k], fname, r.path_of("remesh[" + std::to_string(k) + "]"));
          ph.remeshers.push_back(remesher_registry<D>().create(s));
        }
        // 3D stages share one editable mesh per pass (same result, no rebuild between stages)
        if constexpr (D == 3) ph.remesh_pass = apply_pass;
      }
      r.finish();
      ex.phases.push_back(std::move(ph));
    }
  }
  if (top.has("success")) read_success(top.child("success"), ex.success);
  else ex.success = SuccessCriteria::defaults();
  if (top.has("output")) {
    JsonReader r = top.child("output");
    r.read("snapshot_every", ex.output.snapshot_every);
    r.expect(ex.output.snapshot_every >= 0, "snapshot_every", "must be >= 0");
    r.read("figures", ex.output.figures);
    r.finish();
  }
  top.finish();
  if (dimension != D) top.fail("dimension", "internal mismatch");
  return ex;
}

template Experiment<2> build_experiment<2>(const ExperimentFile&);
template Experiment<3> build_experiment<3>(const ExperimentFile&);

}  // namespace dsnake
