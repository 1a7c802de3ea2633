// Registration of the external fields, one line per product; each factory reads its options
// struct from the JSON object and range-checks it (the caller has read "type"). Every field
// also accepts "cache": "DIR" (fields/field_cache.h), handled here around the factory; the
// gradient field has no stored state, so it is recomputed even with a cache.
#include "fields/registry.h"

#include "fields/ddgvf.h"
#include "fields/distance.h"
#include "fields/field_cache.h"
#include "fields/gradient.h"
#include "fields/gvf.h"
#include "fields/vfc.h"

#include <nlohmann/json.hpp>

namespace dsnake {

namespace {

template <int D>
std::unique_ptr<ExternalField<D>> make_gradient(JsonReader& reader) {
  GradientFieldOptions o;
  reader.read("sigma", o.sigma);
  reader.read("normalize", o.normalize);
  reader.expect(o.sigma >= 0, "sigma", "must be >= 0 (physical units; 0: no smoothing)");
  return std::make_unique<GradientField<D>>(o);
}

// "sigma", "normalize": the edge map shared by the diffused fields.
void read_edge_map(JsonReader& reader, EdgeMapOptions& o) {
  reader.read("sigma", o.sigma);
  reader.read("normalize", o.normalize);
  reader.expect(o.sigma >= 0, "sigma", "must be >= 0 (physical units; 0: no smoothing)");
}

// "mu", "solver", "tolerance", "iterations", "time_step": the GVF solve (GVF and DDGVF).
void read_gvf_solve(JsonReader& reader, GvfSolveOptions& o) {
  reader.read("mu", o.mu);
  reader.read("solver", o.solver);
  reader.read("tolerance", o.tolerance);
  reader.read("iterations", o.iterations);
  reader.read("time_step", o.time_step);
  reader.expect(o.mu > 0, "mu", "must be > 0 (diffusion weight)");
  reader.expect(o.solver == "multigrid" || o.solver == "explicit", "solver", "must be \"multigrid\" or \"explicit\"");
  reader.expect(o.tolerance >= 0 && o.tolerance < 1, "tolerance", "must be in [0, 1) (relative residual; 0: run all iterations)");
  reader.expect(o.iterations >= 0, "iterations", "must be >= 0 (0: the solver's default cap)");
  reader.expect(o.tolerance > 0 || o.iterations > 0, "iterations", "must be > 0 when tolerance is 0");
  reader.expect(o.time_step >= 0, "time_step", "must be >= 0 (0: 0.9 x the stability bound)");
}

template <int D>
std::unique_ptr<ExternalField<D>> make_gvf(JsonReader& reader) {
  GvfFieldOptions o;
  read_edge_map(reader, o.edge);
  read_gvf_solve(reader, o.solve);
  return std::make_unique<GvfField<D>>(o);
}

template <int D>
std::unique_ptr<ExternalField<D>> make_ddgvf(JsonReader& reader) {
  DdgvfFieldOptions o;
  read_edge_map(reader, o.edge);
  read_gvf_solve(reader, o.solve);
  reader.read("polarity", o.polarity);
  reader.expect(o.polarity == "dark_inside" || o.polarity == "bright_inside", "polarity",
                "must be \"dark_inside\" or \"bright_inside\"");
  return std::make_unique<DdgvfField<D>>(o);
}

template <int D>
std::unique_ptr<ExternalField<D>> make_vfc(JsonReader& reader) {
  VfcFieldOptions o;
  read_edge_map(reader, o.edge);
  reader.read("radius", o.radius);
  reader.read("kernel", o.kernel);
  reader.read("gamma", o.gamma);
  reader.read("epsilon", o.epsilon);
  reader.read("zeta", o.zeta);
  reader.expect(o.radius > 0, "radius", "must be > 0 (physical units; at most the image's extent)");
  reader.expect(o.kernel == "power" || o.kernel == "gaussian", "kernel", "must be \"power\" or \"gaussian\"");
  reader.expect(o.gamma > 0, "gamma", "must be > 0");
  reader.expect(o.epsilon >= 0, "epsilon", "must be >= 0");
  reader.expect(o.zeta >= 0, "zeta", "must be >= 0 (0: radius / 2)");
  return std::make_unique<VfcField<D>>(o);
}

template <int D>
std::unique_ptr<ExternalField<D>> make_distance(JsonReader& reader) {
  DistanceFieldOptions o;
  read_edge_map(reader, o.edge);
  reader.read("threshold", o.threshold);
  reader.expect(o.threshold > 0 && o.threshold <= 1, "threshold", "must be in (0, 1] (fraction of the edge map's maximum)");
  return std::make_unique<DistanceField<D>>(o);
}

// Wraps a factory so that the field reads "cache": "DIR" and, when given, comes wrapped in a
// CachedField keyed by the rest of its JSON object (dumped with sorted keys).
template <int D>
typename Registry<ExternalField<D>>::Factory cached(typename Registry<ExternalField<D>>::Factory factory) {
  return [factory](JsonReader& reader) -> std::unique_ptr<ExternalField<D>> {
    std::string dir;
    reader.read("cache", dir);
    reader.expect(!reader.has("cache") || !dir.empty(), "cache", "must be a folder name");
    auto field = factory(reader);
    if (dir.empty()) return field;
    nlohmann::json parameters = reader.object();
    parameters.erase("cache");
    return std::make_unique<CachedField<D>>(std::move(field), dir, parameters.dump());
  };
}

}  // namespace

template <int D>
const Registry<ExternalField<D>>& field_registry() {
  static const Registry<ExternalField<D>> registry = [] {
    Registry<ExternalField<D>> r;
    r.add("gradient", cached<D>(make_gradient<D>));
    r.add("gvf", cached<D>(make_gvf<D>));
    r.add("ddgvf", cached<D>(make_ddgvf<D>));
    r.add("vfc", cached<D>(make_vfc<D>));
    r.add("distance", cached<D>(make_distance<D>));
    return r;
  }();
  return registry;
}

template const Registry<ExternalField<2>>& field_registry<2>();
template const Registry<ExternalField<3>>& field_registry<3>();

}  // namespace dsnake
