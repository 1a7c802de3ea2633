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

namespace {
thread_local KeyRecorder* active_recorder = nullptr;
}  // namespace

KeyRecorder::KeyRecorder() { active_recorder = this; }
KeyRecorder::~KeyRecorder() { active_recorder = nullptr; }

void JsonReader::note(const std::string& key, const char* type, const std::string& default_json) {
  if (active_recorder) active_recorder->records.push_back({key, type, default_json});
}

bool JsonReader::has(const std::string& key) const {
  if (active_recorder) note(key, "", "");  // a key asked about is one the reader knows
  return object_->contains(key);
}

static const char* type_name(const nlohmann::json& j) { return j.type_name(); }

void JsonReader::read(const std::string& key, double& value) {
  if (active_recorder) note(key, "number", nlohmann::json(value).dump());
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_number()) fail(key, std::string("expected a number, found ") + type_name(j));
  value = j.get<double>();
  if (!std::isfinite(value)) fail(key, "expected a finite number");
}

void JsonReader::read(const std::string& key, int& value) {
  if (active_recorder) note(key, "integer", std::to_string(value));
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

void JsonReader::read(const std::string& key, bool& value) {
  if (active_recorder) note(key, "boolean", value ? "true" : "false");
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_boolean()) fail(key, std::string("expected true or false, found ") + type_name(j));
  value = j.get<bool>();
}

void JsonReader::read(const std::string& key, std::string& value) {
  if (active_recorder) note(key, "string", nlohmann::json(value).dump());
  if (!has(key)) return;
  seen_.insert(key);
  const auto& j = (*object_)[key];
  if (!j.is_string()) fail(key, std::string("expected a string, found ") + type_name(j));
  value = j.get<std::string>();
}

void JsonReader::read(const std::string& key, std::vector<double>& value) {
  if (active_recorder) note(key, "array", nlohmann::json(value).dump());
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
  if (active_recorder) note(key, "array", nlohmann::json(value).dump());
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
  if (active_recorder) note(key, "object", nlohmann::json(value).dump());
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

const nlohmann::json& JsonReader::raw(const std::string& key) {
  if (active_recorder) note(key, "", "");
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
