// The external fields that an experiment file can name in "field": {"type": ..., ...}, and the
// one key every field object accepts besides its own options: "cache": "DIR" (the field cache,
// fields/field_cache.h).
#pragma once

#include "fields/region.h"
#include "framework/core/external_field.h"
#include "framework/core/registry.h"

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace dsnake {

// Built on first use; one line per field class in registry.cpp. D = 2 or 3. Its create()/read()
// know the fields' own keys only: "cache" is an unknown key there (use read_field_spec).
template <int D>
const Registry<ExternalField<D>>& field_registry();

enum class CacheCompression { kNone, kZlib };
template <>
struct EnumNames<CacheCompression> {
  static constexpr std::array<std::pair<CacheCompression, const char*>, 2> table{
      {{CacheCompression::kNone, "none"}, {CacheCompression::kZlib, "zlib"}}};
};

// The keys every field object takes besides its own options: the field cache
// (fields/field_cache.h).
struct FieldCacheOptions {
  std::optional<std::string> cache;  // absent: no cache
  CacheCompression cache_compression = CacheCompression::kNone;

  template <class V>
  void visit(V& v) {
    v(cache, Key{"cache", "",
                 "folder of the field cache: the computed field is stored there, keyed by the image and the field's "
                 "type and options, and loaded by later runs (fields/field_cache.h)"});
    v(cache_compression, Key{"cache_compression", "",
                             "how new field cache entries are stored: raw single-precision arrays (none) or deflated with "
                             "zlib (smaller, slower to write and read); entries of either kind are read"});
  }
  void check() const {
    if (cache && cache->empty()) throw OptionError{"cache", "must be a non-empty folder name"};
  }
};

// A read and validated "field" object: the registry entry (type, every option with defaults
// made explicit, builder), the cache and the region.
template <int D>
struct FieldSpec {
  PluginSpec<ExternalField<D>> field;
  FieldCacheOptions cache;
  FieldRegionOptions region;  // "region": where the field is computed (fields/region.h)
};

// Reads the cache keys and "region", then the field's "type" and options through
// field_registry<D>(); calls reader.finish(). Throws InputError naming the key.
template <int D>
FieldSpec<D> read_field_spec(JsonReader& reader);

// Builds the field; with a cache, wrapped in a CachedField keyed by the type and the
// canonical JSON of every option (spec.field.options.dump()), so that spelling a default out
// or leaving it implicit hits the same entry.
template <int D>
std::unique_ptr<ExternalField<D>> build_field(const FieldSpec<D>& spec);

// The JSON Schema properties common to every field object: the cache keys and "region", from
// their options' declarations.
nlohmann::ordered_json field_common_schema_properties();

}  // namespace dsnake
