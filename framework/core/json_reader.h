// JsonReader: reads one JSON object into an options struct, key by key, and reports every
// problem as an InputError naming the file and the JSON path ("energies[1].alpha"): wrong
// types, out-of-range values, and (in finish()) keys nobody read. The only place where an
// options struct meets JSON.
#pragma once

#include "framework/core/types.h"

#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace dsnake {

// Named points, {"name": [x, y(, z)], ...}: landmark targets in world coordinates (LPS mm). The
// reader checks that each is an array of numbers; the user of the points checks their length.
using NamedPoints = std::map<std::string, std::vector<double>>;

// Every key that JsonReaders on this thread are asked for while a KeyRecorder lives, with its
// JSON type and the default it had: how the schema learns the keys of readers that are not
// options structs (the phantoms, whose keys depend on their kind).
struct KeyRecord {
  std::string key, type, default_json;  // type: "number", "integer", "boolean", "string", "array"
};
class KeyRecorder {
 public:
  KeyRecorder();
  ~KeyRecorder();
  KeyRecorder(const KeyRecorder&) = delete;
  KeyRecorder& operator=(const KeyRecorder&) = delete;
  std::vector<KeyRecord> records;
};

class JsonReader {
 public:
  // `object` must outlive the reader. Throws InputError if it is not a JSON object.
  JsonReader(const nlohmann::json& object, std::string file, std::string path);

  bool has(const std::string& key) const;
  // Optional keys: leave `value` untouched when the key is absent; throw on a wrong type.
  void read(const std::string& key, double& value);
  void read(const std::string& key, int& value);
  void read(const std::string& key, bool& value);
  void read(const std::string& key, std::string& value);
  void read(const std::string& key, std::vector<double>& value);
  void read(const std::string& key, std::vector<std::string>& value);
  void read(const std::string& key, NamedPoints& value);
  template <int D>
  void read(const std::string& key, Point<D>& value) {
    std::vector<double> v;
    if (!has(key)) {
      std::string text = "[";
      for (int a = 0; a < D; ++a) text += (a ? ", " : "") + std::to_string(value[a]);
      note(key, "array", text + "]");
      return;
    }
    read(key, v);
    if (int(v.size()) != D) fail(key, "expected " + std::to_string(D) + " numbers");
    for (int a = 0; a < D; ++a) value[a] = v[a];
  }
  // Required keys: as read(), but a missing key is an error.
  template <class T>
  void require(const std::string& key, T& value) {
    if (!has(key)) {
      note(key, "", "");  // a recorder learns the key even though the reader fails here
      fail(key, "is required");
    }
    read(key, value);
  }
  // Range checks, after reading: expect(opts.mu > 0, "mu", "must be > 0").
  void expect(bool ok, const std::string& key, const std::string& message) const {
    if (!ok) fail(key, message);
  }
  // A sub-object or array element, marked as read; its own reader checks its keys.
  const nlohmann::json& raw(const std::string& key);
  JsonReader child(const std::string& key);
  // Marks a key as handled by someone else (e.g. "type" and "weight" read by the caller).
  void skip(const std::string& key) { seen_.insert(key); }

  // Throws on the first key that was never read: unknown keys are errors.
  void finish() const;

  // Tells a live KeyRecorder about a key (read() does this for every key it is asked for).
  static void note(const std::string& key, const char* type, const std::string& default_json);

  [[noreturn]] void fail(const std::string& key, const std::string& message) const;
  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  std::string path_of(const std::string& key) const;
  const nlohmann::json& object() const { return *object_; }

 private:
  const nlohmann::json* object_;
  std::string file_, path_;
  std::set<std::string> seen_;
};

}  // namespace dsnake
