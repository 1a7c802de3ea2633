// Registry<Product>: builds an energy, field or remesher by name from its JSON object. Each
// folder registers its products once, explicitly (energies/registry.cpp etc.: one line per
// product), so that nothing depends on static-initialisation order or linker whims.
#pragma once

#include "framework/json_reader.h"

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace dsnake {

template <class Product>
class Registry {
 public:
  // Reads the options from the reader (which has "type" and "weight" marked as handled),
  // range-checks them with reader.expect(), and returns the product.
  using Factory = std::function<std::unique_ptr<Product>(JsonReader& reader)>;

  void add(const std::string& name, Factory factory) { factories_[name] = std::move(factory); }
  bool contains(const std::string& name) const { return factories_.count(name) > 0; }
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& [k, v] : factories_) n.push_back(k);
    return n;
  }

  // Builds the product named by reader's "type" key; unknown names and unknown keys throw.
  std::unique_ptr<Product> create(JsonReader& reader) const {
    std::string type;
    reader.require("type", type);
    auto it = factories_.find(type);
    if (it == factories_.end()) {
      std::string known;
      for (const auto& n : names()) known += (known.empty() ? "" : ", ") + n;
      reader.fail("type", "unknown type \"" + type + "\" (known: " + known + ")");
    }
    auto product = it->second(reader);
    reader.finish();
    return product;
  }

 private:
  std::map<std::string, Factory> factories_;
};

}  // namespace dsnake
