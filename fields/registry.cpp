// Registration of the external fields: one line per field class. Each class declares its name,
// its options (which read and check themselves) and a summary; see framework/core/registry.h. The
// "cache" and "region" keys are read here, around the registry (read_field_spec); the gradient field has no
// stored state, so it is recomputed even with a cache.
#include "fields/registry.h"

#include "fields/ddgvf.h"
#include "fields/distance.h"
#include "fields/field_cache.h"
#include "fields/gradient.h"
#include "fields/gvf.h"
#include "fields/vfc.h"
#include "framework/core/options_schema.h"
#include "framework/core/program_plugins.h"

namespace dsnake {

template <int D>
const Registry<ExternalField<D>>& field_registry() {
  static const Registry<ExternalField<D>> registry = [] {
    Registry<ExternalField<D>> r;
    r.template add<GradientField<D>>();
    r.template add<GvfField<D>>();
    r.template add<DdgvfField<D>>();
    r.template add<VfcField<D>>();
    r.template add<DistanceField<D>>();
    ProgramPlugins<ExternalField<D>>::instance().add_to(r);  // framework/core/program_plugins.h
    return r;
  }();
  return registry;
}

template <int D>
FieldSpec<D> read_field_spec(JsonReader& reader) {
  FieldSpec<D> spec;
  read_options(reader, spec.cache);
  if (reader.has("region")) {
    JsonReader region = reader.child("region");
    read_options(region, spec.region);
    region.finish();
  }
  spec.field = field_registry<D>().read(reader);  // reads "type" and the options, then finish()
  return spec;
}

template <int D>
std::unique_ptr<ExternalField<D>> build_field(const FieldSpec<D>& spec) {
  auto field = spec.field.build();
  if (!spec.cache.cache) return field;
  // The type is part of the key (field_cache_key hashes field->type()); the options text is the
  // canonical JSON of every option, in visit() order.
  return std::make_unique<CachedField<D>>(std::move(field), *spec.cache.cache, spec.field.options.dump(),
                                          spec.cache.cache_compression == CacheCompression::kZlib);
}

nlohmann::ordered_json field_common_schema_properties() {
  nlohmann::ordered_json p = options_schema<FieldCacheOptions>();
  p["region"] = {{"type", "object"},
                 {"description",
                  "where the field is computed: the placed template's bounding box widened by a margin (default), "
                  "or the whole image (fields/region.h)"},
                 {"properties", options_schema<FieldRegionOptions>()},
                 {"additionalProperties", false}};
  return p;
}

template const Registry<ExternalField<2>>& field_registry<2>();
template const Registry<ExternalField<3>>& field_registry<3>();
template FieldSpec<2> read_field_spec<2>(JsonReader&);
template FieldSpec<3> read_field_spec<3>(JsonReader&);
template std::unique_ptr<ExternalField<2>> build_field<2>(const FieldSpec<2>&);
template std::unique_ptr<ExternalField<3>> build_field<3>(const FieldSpec<3>&);

}  // namespace dsnake
