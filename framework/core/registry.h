// Registry<Product>: the energies, fields or remeshers that an experiment file can name, each
// declared once by its class. A plug-in class says what it is and what it reads:
//
//   template <int D> class ExternalEnergy final : public Energy<D> {
//    public:
//     using Options = ExternalOptions;             // with visit() (framework/core/options.h)
//     static constexpr const char* kType = "external";
//     static constexpr const char* kSummary = "the image force of §3.1: q + tau F(q)";
//     explicit ExternalEnergy(const Options& options);  // calls validate_options()
//     std::string type() const override { return kType; }
//   };
//
// and its folder's registry.cpp registers it with one line, `r.add<ExternalEnergy<D>>();`.
// Name, reading, validation, defaults, the JSON Schema and the documentation's key table all
// come from that. Each folder registers its products explicitly, so that nothing depends on
// static-initialisation order or linker whims.
#pragma once

#include "framework/core/json_reader.h"
#include "framework/core/options_schema.h"

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace dsnake {

// A read and validated plug-in, not yet built: its type, its options (every key, for result
// files and cache keys) and how to build it. Reading an experiment file yields these; the
// assembly builds them.
template <class Product>
struct PluginSpec {
  std::string type;
  nlohmann::ordered_json options;
  std::function<std::unique_ptr<Product>()> build;
};

template <class Product>
class Registry {
 public:
  struct Entry {
    std::string name, summary;
    // Reads the options from the object (its "type" already read), validates them; throws
    // InputError naming the file and the path.
    std::function<PluginSpec<Product>(JsonReader&)> read;
    std::function<std::unique_ptr<Product>()> make_default;  // null for a refusal
    nlohmann::ordered_json schema_properties;                // the options' keys
    std::vector<KeyRow> rows;                                // the documentation's key table
  };

  // Registers a plug-in class (see the header comment).
  template <class Plugin>
  void add() {
    using Options = typename Plugin::Options;
    Entry e;
    e.name = Plugin::kType;
    e.summary = Plugin::kSummary;
    e.read = [](JsonReader& reader) {
      Options o = read_options<Options>(reader);
      if constexpr (requires { Plugin::check_options(o); }) {
        try {
          Plugin::check_options(o);
        } catch (const OptionError& e) {
          reader.fail(e.key, e.message);
        }
      }
      return PluginSpec<Product>{Plugin::kType, options_json(o),
                                 [o]() -> std::unique_ptr<Product> { return std::make_unique<Plugin>(o); }};
    };
    e.make_default = []() -> std::unique_ptr<Product> { return std::make_unique<Plugin>(Options{}); };
    e.schema_properties = options_schema<Options>();
    e.rows = options_rows<Options>();
    entries_[e.name] = std::move(e);
  }
  // A name that is refused with a message (e.g. a 3D remeshing stage in a 2D experiment).
  void add_refusal(const std::string& name, const std::string& message) {
    Entry e;
    e.name = name;
    e.read = [message](JsonReader& reader) -> PluginSpec<Product> { reader.fail("type", message); };
    refusals_[name] = std::move(e);
  }

  bool contains(const std::string& name) const { return entries_.count(name) > 0; }
  // The names that can be built, sorted.
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& [k, v] : entries_) n.push_back(k);
    return n;
  }
  const Entry& entry(const std::string& name) const { return entries_.at(name); }

  // Reads the plug-in named by the reader's "type" key; unknown names and unknown keys throw.
  PluginSpec<Product> read(JsonReader& reader) const {
    std::string type;
    reader.require("type", type);
    auto it = entries_.find(type);
    if (it == entries_.end()) {
      const auto refused = refusals_.find(type);
      if (refused != refusals_.end()) refused->second.read(reader);
      std::string known;
      for (const auto& n : names()) known += (known.empty() ? "" : ", ") + n;
      reader.fail("type", "unknown type \"" + type + "\" (known: " + known + ")");
    }
    auto spec = it->second.read(reader);
    reader.finish();
    return spec;
  }
  // Reads and builds at once.
  std::unique_ptr<Product> create(JsonReader& reader) const { return read(reader).build(); }

 private:
  std::map<std::string, Entry> entries_;
  std::map<std::string, Entry> refusals_;
};

}  // namespace dsnake
