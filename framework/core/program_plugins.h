// Plug-ins that a program of its own brings: a program that links dsnake as a library (and, next,
// a binding) can add an energy, a field or a remesher without touching the plug-in folders, by
// calling register_plugin<Product, Plugin>() before the first experiment is read. The plug-in
// folders' registries (energies/registry.cpp, fields/registry.cpp, remesh/registry.cpp) add these
// after their own entries when they are first built; a registration after that, or under a name
// already taken, is a programming error (std::logic_error). Plug-ins inside the plug-in folders
// have their one line in that folder's registry.cpp instead (docs/extending.md).
#pragma once

#include "framework/core/registry.h"

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace dsnake {

template <class Product>
class ProgramPlugins {
 public:
  static ProgramPlugins& instance() {
    static ProgramPlugins plugins;
    return plugins;
  }
  template <class Plugin>
  void add() {
    if (sealed_)
      throw std::logic_error(std::string("register_plugin: \"") + Plugin::kType +
                             "\" comes after the registry's first use; register plug-ins before the first experiment");
    adds_.push_back({Plugin::kType, [](Registry<Product>& r) { r.template add<Plugin>(); }});
  }
  // Adds the registered plug-ins to `registry` (its own entries already in) and seals the list.
  void add_to(Registry<Product>& registry) {
    sealed_ = true;
    for (const auto& [name, add] : adds_) {
      if (registry.contains(name)) throw std::logic_error("register_plugin: \"" + name + "\" is already registered");
      add(registry);
    }
  }

 private:
  struct Add {
    std::string name;
    std::function<void(Registry<Product>&)> add;
  };
  std::vector<Add> adds_;
  bool sealed_ = false;
};

template <class Product, class Plugin>
void register_plugin() {
  ProgramPlugins<Product>::instance().template add<Plugin>();
}

}  // namespace dsnake
