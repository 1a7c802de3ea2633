// Registration of the external fields, one line per product; each factory reads its options
// struct from the JSON object and range-checks it (the caller has read "type").
#include "fields/registry.h"

#include "fields/gradient.h"

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

}  // namespace

template <int D>
const Registry<ExternalField<D>>& field_registry() {
  static const Registry<ExternalField<D>> registry = [] {
    Registry<ExternalField<D>> r;
    r.add("gradient", make_gradient<D>);
    return r;
  }();
  return registry;
}

template const Registry<ExternalField<2>>& field_registry<2>();
template const Registry<ExternalField<3>>& field_registry<3>();

}  // namespace dsnake
