// Registration of the energies, one line per product; each factory reads its options struct
// from the JSON object and range-checks it (the caller has read "type" and "weight").
#include "energies/registry.h"

#include "energies/external.h"
#include "energies/internal.h"

namespace dsnake {

namespace {

template <int D>
std::unique_ptr<Energy<D>> make_internal(JsonReader& reader) {
  InternalOptions o;
  reader.read("alpha", o.alpha);
  reader.read("beta", o.beta);
  reader.read("gamma", o.gamma);
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

}  // namespace

template <int D>
const Registry<Energy<D>>& energy_registry() {
  static const Registry<Energy<D>> registry = [] {
    Registry<Energy<D>> r;
    r.add("internal", make_internal<D>);
    r.add("external", make_external<D>);
    return r;
  }();
  return registry;
}

template const Registry<Energy<2>>& energy_registry<2>();
template const Registry<Energy<3>>& energy_registry<3>();

}  // namespace dsnake
