// TEMPORARY (replaced by fields/registry.h's FieldSpec at the merge of the fields conversion).
#pragma once
#include "fields/registry.h"
#include "framework/registry.h"
#include "framework/external_field.h"

namespace dsnake {
template <int D>
struct FieldSpec {
  PluginSpec<ExternalField<D>> field;
  std::string cache_dir;
};
template <int D>
FieldSpec<D> read_field_spec(JsonReader& reader) {
  FieldSpec<D> s;
  s.field = field_registry<D>().read(reader);
  return s;
}
template <int D>
std::unique_ptr<ExternalField<D>> build_field(const FieldSpec<D>& spec) { return spec.field.build(); }
}  // namespace dsnake
