// Scaling a recipe's lengths to a small structure; see recipe_scale.h.
#include "experiments/spec/recipe_scale.h"

#include "energies/registry.h"
#include "experiments/spec/template_init.h"
#include "fields/registry.h"
#include "framework/core/phase_driver.h"
#include "remesh/registry.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace dsnake {

namespace {

using json = nlohmann::ordered_json;

// x to `digits` significant digits (the printed file then reads 1.104, not 1.1040000000000001).
double round_significant(double x, int digits) {
  if (x == 0 || !std::isfinite(x)) return x;
  const double p = std::pow(10.0, digits - 1 - static_cast<int>(std::floor(std::log10(std::abs(x)))));
  return std::round(x * p) / p;
}

json scaled(const json& value, double f) {
  if (value.is_number()) return round_significant(value.get<double>() * f, 6);
  json out = value;
  if (value.is_array())
    for (auto& x : out)
      if (x.is_number()) x = round_significant(x.get<double>() * f, 6);
  return out;
}

bool is_zero(const json& value) {
  if (value.is_number()) return value.get<double>() == 0.0;
  if (!value.is_array()) return true;
  for (const auto& x : value)
    if (!x.is_number() || x.get<double>() != 0.0) return false;
  return true;
}

// Scales the length keys of `object` listed in `rows`, their defaults from `properties` (the
// options' JSON Schema properties).
void scale_object(json& object, const std::vector<KeyRow>& rows, const json& properties, double k) {
  if (!object.is_object()) return;
  for (const KeyRow& row : rows) {
    if (row.unit != "mm") continue;
    const double f = k;
    if (object.contains(row.name)) {
      object[row.name] = scaled(object[row.name], f);
      continue;
    }
    const auto p = properties.find(row.name);
    if (p == properties.end() || !p->contains("default")) continue;
    const json& d = (*p)["default"];
    if ((d.is_number() || d.is_array()) && !is_zero(d)) object[row.name] = scaled(d, f);
  }
}

template <class O>
void scale_options(json& object, double k) {
  scale_object(object, options_rows<O>(), options_schema<O>(), k);
}

template <class Product>
void scale_plugin(json& object, const Registry<Product>& registry, double k) {
  if (!object.is_object() || !object.contains("type") || !object["type"].is_string()) return;
  const std::string type = object["type"].get<std::string>();
  if (!registry.contains(type)) return;
  const auto& entry = registry.entry(type);
  scale_object(object, entry.rows, entry.schema_properties, k);
}

template <int D>
void scale_lengths_d(json& j, double k) {
  if (j.contains("field")) {
    scale_plugin(j["field"], field_registry<D>(), k);
    if (j["field"].contains("region")) scale_options<FieldRegionOptions>(j["field"]["region"], k);
  }
  if (j.contains("energies"))
    for (auto& e : j["energies"]) scale_plugin(e, energy_registry<D>(), k);
  if (j.contains("template") && j["template"].contains("init"))
    scale_options<TemplateInitOptions>(j["template"]["init"], k);
  if (j.contains("phases"))
    for (auto& p : j["phases"]) {
      scale_options<PhaseOptions>(p, k);
      if (p.contains("remesh"))
        for (auto& s : p["remesh"]) scale_plugin(s, remesher_registry<D>(), k);
    }
}

}  // namespace

template <int D>
double equivalent_radius(const Template<D>& t) {
  const double m = std::abs(signed_measure<D>(t.positions, t.connectivity));
  if (D == 3) return std::cbrt(3.0 * m / (4.0 * std::numbers::pi));
  return std::sqrt(m / std::numbers::pi);
}

double recipe_length_scale(double r) {
  if (!(r > 0) || !std::isfinite(r)) return 1.0;
  return std::min(1.0, round_significant(r / kRecipeRadiusMm, 3));
}

void scale_lengths(json& experiment, int dimension, double k) {
  if (k == 1.0) return;
  if (dimension == 3) scale_lengths_d<3>(experiment, k);
  else scale_lengths_d<2>(experiment, k);
}

template <int D>
double coarsen_patches_d(json& j, double h) {
  double largest = 1.0;
  if (!j.contains("energies")) return largest;
  const auto& registry = energy_registry<D>();
  for (auto& e : j["energies"]) {
    if (!e.is_object() || e.value("type", "") != "patch" || !registry.contains("patch")) continue;
    const auto& entry = registry.entry("patch");
    const double sigma = e.contains("sigma") ? e["sigma"].get<double>()
                                             : entry.schema_properties["sigma"]["default"].template get<double>();
    if (!(sigma > 0) || !(sigma < h / 4)) continue;
    const double f = round_significant(h / (4 * sigma), 3);
    std::vector<KeyRow> rows;
    for (const KeyRow& row : entry.rows)
      if (row.name == "sigma" || row.name == "radius" || row.name == "spacing") rows.push_back(row);
    scale_object(e, rows, entry.schema_properties, f);
    largest = std::max(largest, f);
  }
  return largest;
}

double coarsen_patches_to_voxels(json& experiment, int dimension, double h) {
  return dimension == 3 ? coarsen_patches_d<3>(experiment, h) : coarsen_patches_d<2>(experiment, h);
}

template double equivalent_radius<2>(const Template<2>&);
template double equivalent_radius<3>(const Template<3>&);

}  // namespace dsnake
