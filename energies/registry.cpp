// Registration of the energies, one line per product; each factory reads its options struct
// from the JSON object and range-checks it (the caller has read "type" and "weight").
#include "energies/registry.h"

#include "energies/arap.h"
#include "energies/asap_mls.h"
#include "energies/balloon.h"
#include "energies/external.h"
#include "energies/internal.h"
#include "energies/laplacian.h"

#include <cmath>

namespace dsnake {

namespace {

template <int D>
std::unique_ptr<Energy<D>> make_internal(JsonReader& reader) {
  InternalOptions o;
  reader.read("alpha", o.alpha);
  reader.read("beta", o.beta);
  reader.read("gamma", o.gamma);
  reader.read("solver", o.solver);
  reader.read("tolerance", o.tolerance);
  reader.expect(o.solver == "auto" || o.solver == "direct" || o.solver == "chebyshev", "solver",
                "must be auto, direct or chebyshev");
  reader.expect(o.tolerance > 0 && o.tolerance < 1, "tolerance", "must be in (0, 1)");
  reader.expect(o.alpha >= 0, "alpha", "must be >= 0");
  reader.expect(o.beta >= 0, "beta", "must be >= 0");
  reader.expect(o.gamma > 0, "gamma", "must be > 0");
  return std::make_unique<InternalEnergy<D>>(o);
}

template <int D>
std::unique_ptr<Energy<D>> make_external(JsonReader& reader) {
  ExternalOptions o;
  reader.read("tau", o.tau);
  reader.expect(o.tau > 0, "tau", "must be > 0");
  return std::make_unique<ExternalEnergy<D>>(o);
}

// asap_mls (D-Snake §4): variant, neighbourhood (k, rings), falloff, weights, iteration, power,
// damping. k is checked against the template size at bind(), which keeps the JSON path for that.
template <int D>
std::unique_ptr<Energy<D>> make_asap_mls(JsonReader& reader) {
  AsapMlsOptions o;
  std::string neighborhood = "rings", weights = "inverse_distance";
  reader.read("variant", o.variant);
  reader.read("neighborhood", neighborhood);
  reader.read("k", o.neighborhood.k);
  reader.read("rings", o.neighborhood.rings);
  reader.read("falloff", o.neighborhood.falloff);
  reader.read("weights", weights);
  const bool has_iteration = reader.has("iteration");
  reader.read("iteration", o.iteration);
  reader.read("power", o.power);
  reader.read("damping", o.damping);
  reader.expect(o.variant == "exact" || o.variant == "approximate", "variant", "must be \"exact\" or \"approximate\"");
  reader.expect(neighborhood == "all" || neighborhood == "k_nearest" || neighborhood == "rings", "neighborhood",
                "must be \"all\", \"k_nearest\" or \"rings\"");
  o.neighborhood.kind = neighborhood == "all" ? NeighborhoodKind::kAll
                        : neighborhood == "k_nearest" ? NeighborhoodKind::kNearest : NeighborhoodKind::kRings;
  reader.expect(o.neighborhood.k >= 1, "k", "must be >= 1");
  reader.expect(o.neighborhood.rings >= 1, "rings", "must be >= 1");
  reader.expect(o.neighborhood.falloff > 0, "falloff", "must be > 0");
  reader.expect(weights == "inverse_distance" || weights == "uniform", "weights", "must be \"inverse_distance\" or \"uniform\"");
  o.neighborhood.uniform = weights == "uniform";
  reader.expect(o.iteration == "jacobi" || o.iteration == "gauss_seidel", "iteration", "must be \"jacobi\" or \"gauss_seidel\"");
  if (D == 3 && o.variant == "exact") {
    if (!has_iteration) o.iteration = "jacobi";
    reader.expect(o.iteration == "jacobi", "iteration",
                  "the 3D exact variant (§4.2) moves every vertex with the others frozen: only \"jacobi\"");
  }
  reader.expect(o.power >= 1, "power", "must be >= 1");
  reader.expect(o.damping > 0 && o.damping <= 1, "damping", "must be in (0, 1]");
  o.file = reader.file();
  o.path = reader.path();
  return std::make_unique<AsapMlsEnergy<D>>(o);
}

template <int D>
std::unique_ptr<Energy<D>> make_laplacian(JsonReader& reader) {
  LaplacianOptions o;
  reader.read("iteration", o.iteration);
  reader.expect(o.iteration == "jacobi" || o.iteration == "gauss_seidel", "iteration", "must be \"jacobi\" or \"gauss_seidel\"");
  return std::make_unique<LaplacianEnergy<D>>(o);
}

template <int D>
std::unique_ptr<Energy<D>> make_arap(JsonReader&) {
  return std::make_unique<ArapEnergy<D>>();
}

template <int D>
std::unique_ptr<Energy<D>> make_balloon(JsonReader& reader) {
  BalloonOptions o;
  reader.read("pressure", o.pressure);
  reader.expect(o.pressure != 0 && std::isfinite(o.pressure), "pressure", "must be a non-zero number");
  return std::make_unique<BalloonEnergy<D>>(o);
}

}  // namespace

template <int D>
const Registry<Energy<D>>& energy_registry() {
  static const Registry<Energy<D>> registry = [] {
    Registry<Energy<D>> r;
    r.add("internal", make_internal<D>);
    r.add("external", make_external<D>);
    r.add("asap_mls", make_asap_mls<D>);
    r.add("laplacian", make_laplacian<D>);
    r.add("arap", make_arap<D>);
    r.add("balloon", make_balloon<D>);
    return r;
  }();
  return registry;
}

template const Registry<Energy<2>>& energy_registry<2>();
template const Registry<Energy<3>>& energy_registry<3>();

}  // namespace dsnake
