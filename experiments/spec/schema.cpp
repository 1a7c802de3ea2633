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

// Per phantom key: the JSON types it is read as, and the kinds that read it.
struct PhantomKey {
  std::set<std::string> types, kinds;
};
using PhantomKeys = std::map<std::string, PhantomKey>;

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

// The keys that phantoms of the given kinds read, recorded while each builds from its defaults
// (a phantom that needs a file fails after reading its keys; what it read so far is kept).
template <class Build>
void record_phantom_keys(const std::vector<std::string>& kinds, const char* section, Build build,
                         PhantomKeys& keys) {
  for (const auto& kind : kinds) {
    nlohmann::json object = {{"phantom", kind}};
    KeyRecorder recorder;
    try {
      JsonReader r(object, "", section);
      build(r);
    } catch (const std::exception&) {
    }
    for (const auto& rec : recorder.records) {
      if (rec.key == "phantom") continue;
      auto& entry = keys[rec.key];
      entry.types.insert(rec.type);
      entry.kinds.insert(kind);
    }
  }
}

// "image" or "template": {"file": path} or {"phantom": kind, the kind's parameters}, plus `own`.
json source_schema(const std::vector<std::string>& kinds,
                   const PhantomKeys& keys, json own,
                   const std::string& description) {
  json props = {{"file", {{"type", "string"}, {"description", "a file, relative to the experiment file's folder"}}},
                {"phantom", {{"enum", kinds}, {"description", "a built-in synthetic phantom with its ground truth"}}}};
  for (const auto& [key, entry] : keys) {
    std::string by;
    for (const auto& k : entry.kinds) by += (by.empty() ? "" : ", ") + k;
    json p = {{"description", "phantom parameter, read by: " + by}};
    std::set<std::string> types = entry.types;
    if (types.count("number")) types.erase("integer");  // an integer is a number
    if (types.count("")) types.erase("");               // asked about (has, raw): no type said
    if (entry.types.size() == 1 && entry.types.count("")) types.clear();  // only raw: any JSON value
    if (types.size() == 1) p["type"] = *types.begin();
    else if (types.size() > 1) p["type"] = std::vector<std::string>(types.begin(), types.end());
    props[key] = p;
  }
  merge(props, own);
  json s = closed_object(props, {}, description);
  s["oneOf"] = json::array({{{"required", {"file"}}}, {{"required", {"phantom"}}}});
  return s;
}

template <int D>
void image_keys(PhantomKeys& keys) {
  record_phantom_keys(image_phantom_kinds<D>(), "image", [](JsonReader& r) { make_phantom<D>(r); }, keys);
}
template <int D>
void template_keys(PhantomKeys& keys) {
  record_phantom_keys(template_phantom_kinds<D>(), "template", [](JsonReader& r) { make_template_phantom<D>(r); }, keys);
}

std::vector<std::string> union_of(std::vector<std::string> a, const std::vector<std::string>& b) {
  for (const auto& x : b)
    if (std::find(a.begin(), a.end(), x) == a.end()) a.push_back(x);
  return a;
}

json corruption_variants() {
  json variants = json::array();
  auto add = [&](const char* type, json props) {
    json p = {{"type", {{"const", type}}}};
    merge(p, props);
    variants.push_back(closed_object(p, {"type"}));
  };
  add("outliers", options_schema<OutliersOptions>());
  add("noise", options_schema<NoiseOptions>());
  add("perturb", options_schema<PerturbOptions>());
  return {{"oneOf", variants}};
}

json template_schema() {
  PhantomKeys keys;
  template_keys<2>(keys);
  template_keys<3>(keys);
  json own = {
      {"reference_image", {{"type", "string"},
                           {"description", "an image in which the template at its rest positions (as read) lies on "
                                           "its object (an atlas, the previous slice): the profile energy's expected "
                                           "profiles are sampled there"}}},
      {"landmarks", {{"type", "object"}, {"additionalProperties", {{"type", "integer"}, {"minimum", 0}}},
                     {"description", "named template vertices: {\"name\": vertex id}"}}},
      {"transform", closed_object({{"scale", {{"type", "number"}, {"exclusiveMinimum", 0}, {"default", 1},
                                              {"description", "uniform scale about the origin"}}},
                                   {"rotation_deg", {{"type", "array"}, {"items", {{"type", "number"}}}, {"maxItems", 3},
                                                     {"description", "2D: one angle; 3D: up to three (x, y, z), degrees"}}},
                                   {"translation", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 2},
                                                    {"maxItems", 3}, {"description", "mm, after scale and rotation"}}}},
                                  {}, "the template's placement: x -> scale R x + translation")},
      {"init", closed_object(options_schema<TemplateInitOptions>(), {"type"},
                             "a pre-alignment after the transform: moments of a region, or a similarity from named landmark points")}};
  return source_schema(union_of(template_phantom_kinds<2>(), template_phantom_kinds<3>()), keys, own,
                       "the template: a contour (2D) or closed mesh (3D) file, or a phantom");
}

json image_schema() {
  PhantomKeys keys;
  image_keys<2>(keys);
  image_keys<3>(keys);
  return source_schema(union_of(image_phantom_kinds<2>(), image_phantom_kinds<3>()), keys,
                       options_schema<ImageReadOptions>(), "the image or volume: a file, or a phantom");
}

json phase_schema() {
  json props = options_schema<PhaseSpec<3>>();
  json stages = plugin_variants(remesher_registry<2>(), remesher_registry<3>(), json::object());
  props["remesh"] = {{"type", "array"}, {"items", stages}, {"description", "remeshing stages, applied in order (§5)"}};
  return closed_object(props);
}

json experiment_definition() {
  json global = options_schema<GlobalSolverOptions>();
  merge(global, options_schema<PotentialOptions>());
  json energy_common = {{"weight", {{"type", "number"}, {"exclusiveMinimum", 0}, {"default", 1},
                                    {"description", "w_e of the term (§3.1's kappa, eta)"}}}};
  json props = {
      {"dimension", {{"enum", {2, 3}}, {"description", "2 (contour on an image) or 3 (mesh in a volume)"}}},
      {"name", {{"type", "string"}, {"description", "names the default output folder out/<name>"}}},
      {"description", {{"type", "string"}}},
      {"seed", {{"type", "integer"}, {"minimum", 0}, {"description", "seeds the corruptions; same seed, same numbers"}}},
      {"solver", {{"enum", {"snake", "global"}}, {"default", "snake"},
                  {"description", "the snake iteration of §3.1 or one global Ceres solve per phase"}}},
      {"collision_guard", closed_object(options_schema<CollisionGuardOptions>(), {},
                                        "the snake iteration's non-self-intersection check")},
      {"global", closed_object(global, {}, "Ceres' options and the external term's potential")},
      {"image", image_schema()},
      {"corruption", {{"type", "array"}, {"items", corruption_variants()}, {"description", "seeded corruptions, in order"}}},
      {"template", template_schema()},
      {"ground_truth", closed_object({{"mask", {{"type", "string"}}}, {"surface", {{"type", "string"}}},
                                      {"correspondence", {{"type", "string"}}}},
                                     {}, "files that override a phantom's own truth")},
      {"field", plugin_variants(field_registry<2>(), field_registry<3>(), field_common_schema_properties())},
      {"energies", {{"type", "array"}, {"minItems", 1},
                    {"items", plugin_variants(energy_registry<2>(), energy_registry<3>(), energy_common)}}},
      {"phases", {{"type", "array"}, {"minItems", 1}, {"items", phase_schema()}}},
      {"success", closed_object(options_schema<SuccessCriteria>(), {}, "thresholds of a successful run")},
      {"output", closed_object(options_schema<OutputOptions>())},
      {"metrics", closed_object(options_schema<MetricsOptions>(), {}, "how the surface distances are sampled")},
      {"watchdog", closed_object(options_schema<WatchdogOptions>(), {}, "when a snake run is stopped as diverged")}};
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
  s += "### `image`: how image files are read\n\n";
  s += key_table_markdown(options_rows<ImageReadOptions>()) + "\n";
  s += "### `collision_guard`: the snake iteration's non-self-intersection check\n\n";
  s += key_table_markdown(options_rows<CollisionGuardOptions>()) + "\n";
  s += "### `global`: Ceres' options and the external term's potential\n\n";
  std::vector<KeyRow> global = options_rows<GlobalSolverOptions>();
  for (const auto& r : options_rows<PotentialOptions>()) global.push_back(r);
  s += key_table_markdown(global) + "\n";
  s += "### `template.init`: the pre-alignment (moments, landmarks or image)\n\n";
  s += key_table_markdown(options_rows<TemplateInitOptions>()) + "\n";
  s += "### `field`\n\nEvery field also takes `cache` (string): a folder of the field cache, and `region` "
       "(object): where the field is computed (fields/region.h). By default the placed template's bounding box "
       "widened on every side by max(margin, margin_share x its largest extent), cut out of the image without "
       "resampling, so that the edge map is normalised near the object and the cost follows the template's size; "
       "a snake that leaves the region feels the force at its border:\n\n";
  s += key_table_markdown(options_rows<FieldRegionOptions>()) + "\n";
  s += plugin_tables("field", field_registry<2>(), field_registry<3>());
  s += "### `energies[i]`\n\nEvery energy also takes `weight` (number > 0, default 1): its w_e.\n\n";
  s += plugin_tables("energies[i]", energy_registry<2>(), energy_registry<3>());
  s += "### `phases[k]`\n\n" + key_table_markdown(options_rows<PhaseSpec<3>>()) +
       "\n`remesh`: an array of stages, applied in order:\n\n";
  s += plugin_tables("phases[k].remesh[j]", remesher_registry<2>(), remesher_registry<3>());
  s += "### `corruption[i]`\n\n";
  s += "#### type `outliers`\n\n" + key_table_markdown(options_rows<OutliersOptions>()) + "\n";
  s += "#### type `noise`\n\n" + key_table_markdown(options_rows<NoiseOptions>()) + "\n";
  s += "#### type `perturb`\n\n" + key_table_markdown(options_rows<PerturbOptions>()) + "\n";
  s += "### `success`\n\n" + key_table_markdown(options_rows<SuccessCriteria>()) + "\n";
  s += "### `output`\n\n" + key_table_markdown(options_rows<OutputOptions>()) + "\n";
  s += "### `metrics`\n\n" + key_table_markdown(options_rows<MetricsOptions>()) + "\n";
  s += "### `watchdog`\n\n" + key_table_markdown(options_rows<WatchdogOptions>());
  return s;
}

}  // namespace dsnake
