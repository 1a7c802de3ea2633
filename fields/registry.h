// The external fields that an experiment file can name in "field": {"type": ..., ...}, and the
// one key every field object accepts besides its own options: "cache": "DIR" (the field cache,
// fields/field_cache.h).
#pragma once

#include "fields/region.h"
#include "framework/core/external_field.h"
#include "framework/core/registry.h"

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

namespace dsnake {

// Built on first use; one line per field class in registry.cpp. D = 2 or 3. Its create()/read()
// know the fields' own keys only: "cache" is an unknown key there (use read_field_spec).
template <int D>
const Registry<ExternalField<D>>& field_registry();

// A read and validated "field" object: the registry entry (type, every option with defaults
// made explicit, builder) and the cache folder ("" = no cache).
template <int D>
struct FieldSpec {
  PluginSpec<ExternalField<D>> field;
  std::string cache_dir;
  bool cache_compressed = false;  // "cache_compression": "zlib" (default "none")
  FieldRegionOptions region;  // "region": where the field is computed (fields/region.h)
};

// Reads "cache" (when given, a non-empty folder name), "cache_compression" and "region", then the field's "type" and options
// through field_registry<D>(); calls reader.finish(). Throws InputError naming the key.
template <int D>
FieldSpec<D> read_field_spec(JsonReader& reader);

// Builds the field; with a cache_dir, wrapped in a CachedField keyed by the type and the
// canonical JSON of every option (spec.field.options.dump()), so that spelling a default out
// or leaving it implicit hits the same entry.
template <int D>
std::unique_ptr<ExternalField<D>> build_field(const FieldSpec<D>& spec);

// The JSON Schema properties common to every field object: {"cache": {"type": "string", ...}}.
nlohmann::ordered_json field_common_schema_properties();

}  // namespace dsnake
