// PhantomRegistry<Product>: the synthetic phantoms an experiment file can name in
// "image": {"phantom": kind, ...} (Product = Phantom<D>) or "template": {"phantom": kind, ...}
// (Product = Template<D>), each family declared once, in the style of the plug-in registries
// (framework/core/registry.h): a name, a summary, an options struct whose visit() lists its keys
// (unit, meaning, range, default; framework/core/options.h) and a builder from those options.
// Reading, checking, the JSON Schema and the documentation's key tables all come from that.
#pragma once

#include "framework/core/json_reader.h"
#include "framework/core/options_schema.h"

#include <any>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace dsnake {

// A read and validated phantom, not yet built: its kind, its options (the family's options
// struct, for the correspondence targets of a pair of phantoms) and how to build it.
template <class Product>
struct PhantomSpec {
  std::string kind;
  std::any options;
  std::function<Product()> build;

  // The family's options, or null if this phantom is of another family.
  template <class Options>
  const Options* options_as() const {
    return std::any_cast<Options>(&options);
  }
};

template <class Product>
class PhantomRegistry {
 public:
  struct Family {
    std::string name, summary;
    // Reads the family's keys (its "phantom" already read), validates them; throws InputError
    // naming the file and the JSON path.
    std::function<PhantomSpec<Product>(JsonReader&)> read;
    nlohmann::ordered_json schema_properties;  // the options' keys
    std::vector<KeyRow> rows;                  // the documentation's key table
  };

  // `what` names the registry in messages: "2D image", "3D template".
  explicit PhantomRegistry(std::string what) : what_(std::move(what)) {}

  // Registers a family: its options struct (visit(), optionally check() and
  // resolve(const JsonReader&) for what needs the file, such as a relative path) and its builder.
  template <class Options>
  void add(const char* name, const char* summary, std::function<Product(const Options&)> build) {
    Family f;
    f.name = name;
    f.summary = summary;
    f.read = [name = std::string(name), build](JsonReader& reader) {
      Options o = read_options<Options>(reader);
      if constexpr (requires { o.resolve(reader); }) o.resolve(reader);
      return PhantomSpec<Product>{name, o, [o, build] { return build(o); }};
    };
    f.schema_properties = options_schema<Options>();
    f.rows = options_rows<Options>();
    families_.push_back(std::move(f));
  }

  // The kinds, in registration order.
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& f : families_) n.push_back(f.name);
    return n;
  }
  const std::vector<Family>& families() const { return families_; }

  // Reads the phantom named by the reader's "phantom" key and its family's keys. Does not call
  // reader.finish(): the section has keys of its own ("transform", "nifti_transform").
  PhantomSpec<Product> read(JsonReader& reader) const {
    std::string kind;
    reader.require("phantom", kind);
    for (const auto& f : families_)
      if (f.name == kind) return f.read(reader);
    std::string known;
    for (const auto& n : names()) known += (known.empty() ? "" : ", ") + n;
    reader.fail("phantom", "unknown " + what_ + " phantom \"" + kind + "\" (known: " + known + ")");
  }

 private:
  std::string what_;
  std::vector<Family> families_;
};

}  // namespace dsnake
