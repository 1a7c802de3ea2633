#include "experiments/spec/schema.h"

#include "energies/registry.h"
#include "experiments/phantoms/corruption.h"
#include "experiments/spec/experiment_spec.h"
#include "experiments/phantoms/phantoms.h"
#include "fields/registry.h"
#include "fields/smooth_potential.h"
#include "framework/core/options_schema.h"
#include "framework/io/image_io.h"
#include "remesh/registry.h"

#include <map>
#include <set>

namespace dsnake {

namespace {

using json = nlohmann::ordered_json;

json closed_object(json properties, const std::vector<std::string>& required = {}, const std::string& description = "") {
  json s = {{"type", "object"}};
  if (!description.empty()) s["description"] = description;
  s["properties"] = std::move(properties);
  if (!required.empty()) s["required"] = required;
  s["additionalProperties"] = false;
  return s;
}

void merge(json& into, const json& from) {
  for (auto it = from.begin(); it != from.end(); ++it) into[it.key()] = it.value();
}

// A registered name of the 2D or 3D registry (the 3D entry where both have it), with the
// dimensions that offer it: what the schema and the key tables both list.
struct PluginEntry {
  std::string summary, dims;
  json schema;
  std::vector<KeyRow> rows;
};
template <class R2, class R3>
std::map<std::string, PluginEntry> entries_by_name(const R2& r2, const R3& r3) {
  std::map<std::string, PluginEntry> by_name;
  for (const auto& n : r2.names()) by_name[n] = {r2.entry(n).summary, "2D", r2.entry(n).schema_properties, r2.entry(n).rows};
  for (const auto& n : r3.names()) {
    const std::string dims = by_name.count(n) ? "2D and 3D" : "3D";
    by_name[n] = {r3.entry(n).summary, dims, r3.entry(n).schema_properties, r3.entry(n).rows};
  }
  return by_name;
}

// One variant per registered name: {"type": const name, common keys, the options' keys}.
template <class R2, class R3>
json plugin_variants(const R2& r2, const R3& r3, const json& common) {
  json variants = json::array();
  for (const auto& [name, entry] : entries_by_name(r2, r3)) {
    json props = {{"type", {{"const", name}, {"description", entry.summary}}}};
    merge(props, common);
    merge(props, entry.schema);
    variants.push_back(closed_object(props, {"type"}));
  }
  return {{"oneOf", variants}};
}

// The union of the 2D and 3D properties of one options struct (e.g. a point of 2 or 3
// numbers): where they differ, the item counts widen and the default is dropped.
json union_of_dims(const json& p2, const json& p3) {
  json u = p3;
  for (auto it = p2.begin(); it != p2.end(); ++it) {
    if (!u.contains(it.key())) {
      u[it.key()] = it.value();
      continue;
    }
    json& k = u[it.key()];
    if (k == it.value()) continue;
    if (k.contains("minItems") && it->contains("minItems"))
      k["minItems"] = std::min(k["minItems"].get<int>(), (*it)["minItems"].get<int>());
    if (k.contains("maxItems") && it->contains("maxItems"))
      k["maxItems"] = std::max(k["maxItems"].get<int>(), (*it)["maxItems"].get<int>());
    k.erase("default");
  }
  return u;
}

// One variant per phantom family of each dimension: {"phantom": const kind, the family's keys,
// the section's own keys}; anyOf, as a kind may exist in 2D and 3D with different keys.
template <class R>
void add_phantom_variants(json& variants, const R& registry, const char* dims, const json& own) {
  for (const auto& f : registry.families()) {
    json props = {{"phantom", {{"const", f.name}, {"description", std::string(dims) + ": " + f.summary}}}};
    merge(props, f.schema_properties);
    merge(props, own);
    variants.push_back(closed_object(props, {"phantom"}));
  }
}

// "image" or "template": {"file": path} or {"phantom": kind, the kind's parameters}, plus `own`.
template <class R2, class R3>
json source_schema(const R2& r2, const R3& r3, const json& own, const std::string& description) {
  json file = {{"file", {{"type", "string"}, {"description", "a file, relative to the experiment file's folder"}}}};
  merge(file, own);
  json variants = json::array({closed_object(file, {"file"})});
  add_phantom_variants(variants, r2, "2D", own);
  add_phantom_variants(variants, r3, "3D", own);
  return {{"type", "object"}, {"description", description}, {"anyOf", variants}};
}

json corruption_variants() {
  json variants = json::array();
  for (const auto& kind : corruption_kinds()) {
    json p = {{"type", {{"const", kind.name}, {"description", kind.summary}}}};
    merge(p, kind.schema_properties);
    variants.push_back(closed_object(p, {"type"}));
  }
  return {{"oneOf", variants}};
}

json template_schema() {
  json own = options_schema<TemplateSpec<3>>();
  own["transform"] = closed_object(union_of_dims(options_schema<PlacementSpec<2>>(), options_schema<PlacementSpec<3>>()), {},
                                   "the template's placement: x -> scale R x + translation");
  own["transform"]["properties"]["rotation_deg"]["maxItems"] = 3;  // PlacementSpec::check: one angle in 2D
  own["init"] = closed_object(options_schema<TemplateInitOptions>(), {"type"},
                              "a pre-alignment after the transform: moments of a region, or a similarity from named landmark points");
  return source_schema(template_phantoms<2>(), template_phantoms<3>(), own,
                       "the template: a contour (2D) or closed mesh (3D) file, or a phantom");
}

json image_schema() {
  return source_schema(image_phantoms<2>(), image_phantoms<3>(), options_schema<ImageReadOptions>(),
                       "the image or volume: a file, or a phantom");
}

json phase_schema() {
  json props = options_schema<PhaseOptions>();
  json stages = plugin_variants(remesher_registry<2>(), remesher_registry<3>(), json::object());
  props["remesh"] = {{"type", "array"}, {"items", stages}, {"description", "remeshing stages, applied in order (§5)"}};
  return closed_object(props);
}

json experiment_definition() {
  json global = options_schema<GlobalSolverOptions>();
  merge(global, options_schema<PotentialOptions>());
  json props = options_schema<RunKeys>();
  props["dimension"].erase("default");  // required
  merge(props, json{
      {"collision_guard", closed_object(options_schema<CollisionGuardOptions>(), {},
                                        "the snake iteration's non-self-intersection check")},
      {"global", closed_object(global, {}, "Ceres' options and the external term's potential")},
      {"image", image_schema()},
      {"corruption", {{"type", "array"}, {"items", corruption_variants()}, {"description", "seeded corruptions, in order"}}},
      {"template", template_schema()},
      {"ground_truth", closed_object(options_schema<GroundTruthSpec>(), {}, "files that override a phantom's own truth")},
      {"field", plugin_variants(field_registry<2>(), field_registry<3>(), field_common_schema_properties())},
      {"energies", {{"type", "array"}, {"minItems", 1},
                    {"items", plugin_variants(energy_registry<2>(), energy_registry<3>(), options_schema<EnergyWeight>())}}},
      {"phases", {{"type", "array"}, {"minItems", 1}, {"items", phase_schema()}}},
      {"success", closed_object(options_schema<SuccessCriteria>(), {}, "thresholds of a successful run")},
      {"output", closed_object(options_schema<OutputOptions>())},
      {"metrics", closed_object(options_schema<MetricsOptions>(), {}, "how the surface distances are sampled")},
      {"watchdog", closed_object(options_schema<WatchdogOptions>(), {}, "when a snake run is stopped as diverged")}});
  return closed_object(props, {"dimension", "image", "template", "field", "energies", "phases"}, "an experiment file");
}

json sweep_definition() {
  json props = {
      {"description", {{"type", "string"}}},
      {"base", {{"type", "string"}, {"description", "the experiment file every run starts from"}}},
      {"grid", {{"type", "object"}, {"additionalProperties", {{"type", "array"}, {"minItems", 1}}},
                {"description", "key path -> values; every combination runs"}}},
      {"corruptions", {{"type", "array"}, {"minItems", 1}, {"items", {{"type", "array"}, {"items", corruption_variants()}}}}},
      {"seeds", {{"oneOf", json::array({{{"type", "array"}, {"items", {{"type", "integer"}, {"minimum", 0}}}},
                                        closed_object({{"count", {{"type", "integer"}, {"minimum", 1}}},
                                                       {"first", {{"type", "integer"}, {"minimum", 0}}}},
                                                      {"count"})})}}},
      {"methods", {{"type", "object"},
                   {"additionalProperties", closed_object({{"base", {{"type", "string"}}}, {"overrides", {{"type", "object"}}}})}}},
      {"success", closed_object(options_schema<SuccessCriteria>())}};
  return closed_object(props, {"base"}, "a sweep file: methods x grid x corruption levels x seeds over a base experiment");
}

// Markdown: a heading, a summary line and the key table of each variant of a registry.
template <class R2, class R3>
std::string plugin_tables(const char* section, const R2& r2, const R3& r3) {
  std::string s;
  for (const auto& [name, entry] : entries_by_name(r2, r3))
    s += "#### `" + std::string(section) + "` type `" + name + "` (" + entry.dims + ")\n\n" + entry.summary + ".\n\n" +
         key_table_markdown(entry.rows) + "\n";
  return s;
}

// Markdown: a heading, a summary line and the key table of each phantom family.
template <class R>
std::string phantom_tables(const char* section, const R& registry, const char* dims) {
  std::string s;
  for (const auto& f : registry.families())
    s += "#### `" + std::string(section) + "` phantom `" + f.name + "` (" + dims + ")\n\n" + f.summary + ".\n\n" +
         key_table_markdown(f.rows) + "\n";
  return s;
}

}  // namespace

nlohmann::ordered_json experiment_schema() {
  json s = {{"$schema", "https://json-schema.org/draft/2020-12/schema"},
            {"title", "dsnake experiment or sweep file"},
            {"description", "docs/experiment-file.md; generated by `dsnake schema`"},
            {"oneOf", json::array({{{"$ref", "#/$defs/experiment"}}, {{"$ref", "#/$defs/sweep"}}})}};
  s["$defs"] = {{"experiment", experiment_definition()}, {"sweep", sweep_definition()}};
  return s;
}

std::string experiment_reference_markdown() {
  std::string s;
  s += "### Top-level keys: the run\n\n";
  std::vector<KeyRow> run = options_rows<RunKeys>();
  run.front().default_value = "required";
  s += key_table_markdown(run) + "\n";
  s += "### `image`: how image files are read\n\n";
  s += key_table_markdown(options_rows<ImageReadOptions>()) + "\n";
  s += "### `image` phantoms\n\nEvery image phantom takes the canvas keys (`size` to `center`) and its family's own.\n\n";
  s += phantom_tables("image", image_phantoms<2>(), "2D") + phantom_tables("image", image_phantoms<3>(), "3D");
  s += "### `template`\n\n" + key_table_markdown(options_rows<TemplateSpec<3>>()) + "\n";
  s += "### `template.transform`: the placement\n\nx -> scale R x + translation about the template's centroid; in 2D, "
       "`rotation_deg` has one angle and `translation` two numbers.\n\n";
  s += key_table_markdown(options_rows<PlacementSpec<3>>()) + "\n";
  s += "### `template` phantoms\n\n";
  s += phantom_tables("template", template_phantoms<2>(), "2D") + phantom_tables("template", template_phantoms<3>(), "3D");
  s += "### `ground_truth`\n\n" + key_table_markdown(options_rows<GroundTruthSpec>()) + "\n";
  s += "### `collision_guard`: the snake iteration's non-self-intersection check\n\n";
  s += key_table_markdown(options_rows<CollisionGuardOptions>()) + "\n";
  s += "### `global`: Ceres' options and the external term's potential\n\n";
  std::vector<KeyRow> global = options_rows<GlobalSolverOptions>();
  for (const auto& r : options_rows<PotentialOptions>()) global.push_back(r);
  s += key_table_markdown(global) + "\n";
  s += "### `template.init`: the pre-alignment (moments, landmarks or image)\n\n";
  s += key_table_markdown(options_rows<TemplateInitOptions>()) + "\n";
  s += "### `field`\n\nEvery field also takes the cache keys:\n\n" + key_table_markdown(options_rows<FieldCacheOptions>()) +
       "\nand `region` (object): where the field is computed (fields/region.h). By default the placed template's bounding box "
       "widened on every side by max(margin, margin_share x its largest extent), cut out of the image without "
       "resampling, so that the edge map is normalised near the object and the cost follows the template's size; "
       "a snake that leaves the region feels the force at its border:\n\n";
  s += key_table_markdown(options_rows<FieldRegionOptions>()) + "\n";
  s += plugin_tables("field", field_registry<2>(), field_registry<3>());
  s += "### `energies[i]`\n\nEvery energy also takes:\n\n" + key_table_markdown(options_rows<EnergyWeight>()) + "\n";
  s += plugin_tables("energies[i]", energy_registry<2>(), energy_registry<3>());
  s += "### `phases[k]`\n\n" + key_table_markdown(options_rows<PhaseOptions>()) +
       "\n`remesh`: an array of stages, applied in order:\n\n";
  s += plugin_tables("phases[k].remesh[j]", remesher_registry<2>(), remesher_registry<3>());
  s += "### `corruption[i]`\n\n";
  for (const auto& kind : corruption_kinds())
    s += "#### type `" + kind.name + "`\n\n" + kind.summary + ".\n\n" + key_table_markdown(kind.rows) + "\n";
  s += "### `success`\n\n" + key_table_markdown(options_rows<SuccessCriteria>()) + "\n";
  s += "### `output`\n\n" + key_table_markdown(options_rows<OutputOptions>()) + "\n";
  s += "### `metrics`\n\n" + key_table_markdown(options_rows<MetricsOptions>()) + "\n";
  s += "### `watchdog`\n\n" + key_table_markdown(options_rows<WatchdogOptions>());
  return s;
}

}  // namespace dsnake
