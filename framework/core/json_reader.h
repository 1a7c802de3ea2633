// JsonReader: reads one JSON object into an options struct, key by key, and reports every
// problem as an InputError naming the file and the JSON path ("energies[1].alpha"): wrong
// types, out-of-range values, and (in finish()) keys nobody read. The only place where an
// options struct meets JSON.
#pragma once

#include "framework/core/types.h"

#include <cstdint>
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
// Named vertex ids, {"name": id, ...}: landmarks of a template. The reader checks that each is
// an integer >= 0; the user checks it against the template's size.
using VertexIds = std::map<std::string, int>;

class JsonReader {
 public:
  // `object` must outlive the reader. Throws InputError if it is not a JSON object.
  JsonReader(const nlohmann::json& object, std::string file, std::string path);

  bool has(const std::string& key) const;
  // Optional keys: leave `value` untouched when the key is absent; throw on a wrong type.
  void read(const std::string& key, double& value);
  void read(const std::string& key, int& value);
  void read(const std::string& key, uint64_t& value);  // a non-negative integer below 2^53 (a seed)
  void read(const std::string& key, bool& value);
  void read(const std::string& key, std::string& value);
  void read(const std::string& key, std::vector<double>& value);
  void read(const std::string& key, std::vector<std::string>& value);
  void read(const std::string& key, NamedPoints& value);
  void read(const std::string& key, VertexIds& value);
  // A non-empty array of [x, y, z] points.
  void read(const std::string& key, PointList<3>& value);
  template <int D>
  void read(const std::string& key, Point<D>& value) {
    std::vector<double> v;
    if (!has(key)) return;
    read(key, v);
    if (int(v.size()) != D) fail(key, "expected " + std::to_string(D) + " numbers");
    for (int a = 0; a < D; ++a) value[a] = v[a];
  }
  // Required keys: as read(), but a missing key is an error.
  template <class T>
  void require(const std::string& key, T& value) {
    if (!has(key)) fail(key, "is required");
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
