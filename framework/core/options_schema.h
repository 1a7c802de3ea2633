// What an options struct's visit() list says about its keys, for people and for editors: the
// JSON Schema properties of the keys (type, default, range, enum names, description with the
// unit), the canonical JSON of a set of values (field cache keys, result.json), and the rows of
// the key tables in docs/experiment-file.md. See framework/core/options.h.
#pragma once

#include "framework/core/options.h"
#include "framework/core/types.h"

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace dsnake {

// One row of a key table: `name` | type | unit | default | range | meaning.
struct KeyRow {
  std::string name, type, unit, default_value, range, help;
};

namespace options_detail {

template <class T>
struct TypeInfo;
template <> struct TypeInfo<double> { static constexpr const char* json = "number"; static constexpr const char* doc = "number"; };
template <> struct TypeInfo<int> { static constexpr const char* json = "integer"; static constexpr const char* doc = "integer"; };
template <> struct TypeInfo<bool> { static constexpr const char* json = "boolean"; static constexpr const char* doc = "boolean"; };
template <> struct TypeInfo<std::string> { static constexpr const char* json = "string"; static constexpr const char* doc = "string"; };
template <> struct TypeInfo<std::vector<double>> { static constexpr const char* json = "array"; static constexpr const char* doc = "array of numbers"; };
template <> struct TypeInfo<std::vector<std::string>> { static constexpr const char* json = "array"; static constexpr const char* doc = "array of strings"; };
template <> struct TypeInfo<Point<2>> { static constexpr const char* json = "array"; static constexpr const char* doc = "array of 2 numbers"; };
template <> struct TypeInfo<Point<3>> { static constexpr const char* json = "array"; static constexpr const char* doc = "array of 3 numbers"; };
template <> struct TypeInfo<PointList<3>> { static constexpr const char* json = "array"; static constexpr const char* doc = "array of [x, y, z]"; };
template <> struct TypeInfo<uint64_t> { static constexpr const char* json = "integer"; static constexpr const char* doc = "integer"; };
template <> struct TypeInfo<VertexIds> { static constexpr const char* json = "object"; static constexpr const char* doc = "object {name: vertex id}"; };
template <> struct TypeInfo<NamedPoints> { static constexpr const char* json = "object"; static constexpr const char* doc = "object {name: [x, y(, z)]}"; };

template <class T>
nlohmann::ordered_json value_json(const T& value) {
  if constexpr (IsOptional<T>::value) return value ? value_json(*value) : nlohmann::ordered_json(nullptr);
  else if constexpr (NamedEnum<T>) return enum_name(value);
  else if constexpr (IsPoint<T>::value) return std::vector<double>(value.data(), value.data() + value.size());
  else if constexpr (std::is_same_v<T, PointList<3>>) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const auto& p : value) list.push_back(value_json(p));
    return list;
  } else return value;
}

// The JSON Schema bounds of a range ("minimum", "exclusiveMaximum", ...).
inline nlohmann::ordered_json range_schema(const Range& r) {
  nlohmann::ordered_json p = nlohmann::ordered_json::object();
  if (r.bounded_below()) p[r.min_open ? "exclusiveMinimum" : "minimum"] = r.min;
  if (r.bounded_above()) p[r.max_open ? "exclusiveMaximum" : "maximum"] = r.max;
  return p;
}

// JSON Schema "properties" of the keys, with each key's default and range.
class SchemaVisitor {
 public:
  template <class T>
  void operator()(const std::optional<T>& value, const Key& key) {  // absent by default
    (*this)(value ? *value : T{}, key);
    if (!value) properties[key.name].erase("default");
  }
  template <class T>
  void operator()(const T& value, const Key& key) {
    nlohmann::ordered_json p;
    std::string description = key.help;
    if (*key.unit) description += " [" + std::string(key.unit) + "]";
    p["description"] = description;
    if constexpr (NamedEnum<T>) {
      p["type"] = "string";
      nlohmann::ordered_json names = nlohmann::ordered_json::array();
      for (const auto& [v, n] : EnumNames<T>::table) names.push_back(n);
      p["enum"] = names;
    } else {
      p["type"] = TypeInfo<T>::json;
      if constexpr (std::is_same_v<T, std::vector<double>>) p["items"] = {{"type", "number"}};
      if constexpr (std::is_same_v<T, std::vector<std::string>>) p["items"] = {{"type", "string"}};
      if constexpr (std::is_same_v<T, VertexIds>) p["additionalProperties"] = {{"type", "integer"}, {"minimum", 0}};
      if constexpr (std::is_same_v<T, NamedPoints>)
        p["additionalProperties"] = {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 2}, {"maxItems", 3}};
      if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) p.update(range_schema(key.range));
      if constexpr (IsPoint<T>::value) {
        nlohmann::ordered_json items = {{"type", "number"}};
        items.update(range_schema(key.range));
        p["items"] = items;
        p["minItems"] = p["maxItems"] = IsPoint<T>::kDim;
      }
      if constexpr (std::is_same_v<T, PointList<3>>)
        p["items"] = {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}};
    }
    p["default"] = value_json(value);
    properties[key.name] = p;
  }
  nlohmann::ordered_json properties = nlohmann::ordered_json::object();
};

// The values as a JSON object, every key present (defaults made explicit), in visit() order.
struct ValueVisitor {
  template <class T>
  void operator()(const T& value, const Key& key) { values[key.name] = value_json(value); }
  nlohmann::ordered_json values = nlohmann::ordered_json::object();
};

struct RowVisitor {
  template <class T>
  void operator()(const std::optional<T>& value, const Key& key) {
    (*this)(value ? *value : T{}, key);
    if (!value) rows.back().default_value = "none";
  }
  template <class T>
  void operator()(const T& value, const Key& key) {
    KeyRow row;
    row.name = key.name;
    row.unit = key.unit;
    row.help = key.help;
    if constexpr (NamedEnum<T>) {
      row.type = "one of " + enum_choices<T>();
    } else {
      row.type = TypeInfo<T>::doc;
      if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) row.range = key.range.text();
      if constexpr (IsPoint<T>::value)
        if (key.range.bounded_below() || key.range.bounded_above()) row.range = "each in " + key.range.text();
    }
    row.default_value = value_json(value).dump();
    rows.push_back(row);
  }
  std::vector<KeyRow> rows;
};

}  // namespace options_detail

// The JSON Schema "properties" object of an options struct, from the values of `defaults`.
template <class O>
nlohmann::ordered_json options_schema(const O& defaults = O{}) {
  options_detail::SchemaVisitor v;
  const_cast<O&>(defaults).visit(v);
  return v.properties;
}

// The options as a JSON object with every key.
template <class O>
nlohmann::ordered_json options_json(const O& options) {
  options_detail::ValueVisitor v;
  const_cast<O&>(options).visit(v);
  return v.values;
}

// The key table rows of an options struct, from the values of `defaults`.
template <class O>
std::vector<KeyRow> options_rows(const O& defaults = O{}) {
  options_detail::RowVisitor v;
  const_cast<O&>(defaults).visit(v);
  return v.rows;
}

// A markdown table of the rows (header included).
std::string key_table_markdown(const std::vector<KeyRow>& rows);

}  // namespace dsnake
