#include "framework/core/json_reader.h"

#include "framework/core/errors.h"

#include <cmath>
#include <nlohmann/json.hpp>

namespace dsnake {

JsonReader::JsonReader(const nlohmann::json& object, std::string file, std::string path)
    : object_(&object), file_(std::move(file)), path_(std::move(path)) {
  if (!object.is_object())
    throw InputError(file_, path_.empty() ? "(top level)" : path_, "expected a JSON object");
}

std::string JsonReader::path_of(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void JsonReader::fail(const std::string& key, const std::string& message) const {
  throw InputError(file_, key.empty() ? path_ : path_of(key), message);
}

bool JsonReader::has(const std::string& key) const {
  return object_->contains(key);
}

static const char* type_name(const nlohmann::json& j) { return j.type_name(); }

void JsonReader::read(const std::string& key, double& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_number()) fail(key, std::string("expected a number, found ") + type_name(j));
  value = j.get<double>();
  if (!std::isfinite(value)) fail(key, "expected a finite number");
}

void JsonReader::read(const std::string& key, int& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (j.is_number_float()) {
    const double d = j.get<double>();
    if (d != std::floor(d) || std::abs(d) > 2e9) fail(key, "expected an integer, found " + j.dump());
    value = static_cast<int>(d);
    return;
  }
  if (!j.is_number_integer()) fail(key, std::string("expected an integer, found ") + type_name(j));
  const auto v = j.get<int64_t>();
  if (v > 2000000000 || v < -2000000000) fail(key, "integer out of range");
  value = static_cast<int>(v);
}

void JsonReader::read(const std::string& key, uint64_t& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_number()) fail(key, std::string("expected a number, found ") + type_name(j));
  const double d = j.get<double>();
  if (!(d >= 0 && d == std::floor(d) && d < 9.007e15)) fail(key, "must be a non-negative integer");
  value = j.is_number_unsigned() ? j.get<uint64_t>() : static_cast<uint64_t>(d);
}

void JsonReader::read(const std::string& key, bool& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_boolean()) fail(key, std::string("expected true or false, found ") + type_name(j));
  value = j.get<bool>();
}

void JsonReader::read(const std::string& key, std::string& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_string()) fail(key, std::string("expected a string, found ") + type_name(j));
  value = j.get<std::string>();
}

void JsonReader::read(const std::string& key, std::vector<double>& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_array()) fail(key, std::string("expected an array of numbers, found ") + type_name(j));
  value.clear();
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number())
      fail(key + "[" + std::to_string(i) + "]", std::string("expected a number, found ") + type_name(j[i]));
    value.push_back(j[i].get<double>());
  }
}

void JsonReader::read(const std::string& key, std::vector<std::string>& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_array()) fail(key, std::string("expected an array of strings, found ") + type_name(j));
  value.clear();
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_string())
      fail(key + "[" + std::to_string(i) + "]", std::string("expected a string, found ") + type_name(j[i]));
    value.push_back(j[i].get<std::string>());
  }
}

void JsonReader::read(const std::string& key, NamedPoints& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_object()) fail(key, std::string("expected an object {\"name\": [x, y(, z)]}, found ") + type_name(j));
  value.clear();
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string where = key + "." + it.key();
    if (!it->is_array()) fail(where, std::string("expected an array of numbers, found ") + type_name(*it));
    std::vector<double>& point = value[it.key()];
    for (size_t i = 0; i < it->size(); ++i) {
      if (!(*it)[i].is_number() || !std::isfinite((*it)[i].get<double>()))
        fail(where + "[" + std::to_string(i) + "]", "expected a finite number");
      point.push_back((*it)[i].get<double>());
    }
  }
}

void JsonReader::read(const std::string& key, VertexIds& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_object()) fail(key, "expected an object {\"name\": vertex id}");
  value.clear();
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!it->is_number_integer() || it->get<int64_t>() < 0 || it->get<int64_t>() > 2000000000)
      fail(key + "." + it.key(), "expected a template vertex id (an integer >= 0)");
    value[it.key()] = it->get<int>();
  }
}

void JsonReader::read(const std::string& key, PointList<3>& value) {
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_array() || j.empty()) fail(key, "expected a non-empty array of [x, y, z]");
  value.clear();
  for (const auto& c : j) {
    if (!c.is_array() || c.size() != 3 || !c[0].is_number() || !c[1].is_number() || !c[2].is_number())
      fail(key, "expected an array of [x, y, z] points");
    value.emplace_back(c[0].get<double>(), c[1].get<double>(), c[2].get<double>());
  }
}

const nlohmann::json& JsonReader::raw(const std::string& key) {
  if (!has(key)) fail(key, "is required");
  seen_.insert(key);
  return (*object_)[key];
}

JsonReader JsonReader::child(const std::string& key) {
  return JsonReader(raw(key), file_, path_of(key));
}

void JsonReader::finish() const {
  for (auto it = object_->begin(); it != object_->end(); ++it)
    if (!seen_.count(it.key())) fail(it.key(), "unknown key");
}

}  // namespace dsnake
