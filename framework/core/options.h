// Options that read and check themselves (in the spirit of Ceres' Solver::Options::IsValid).
// An options struct lists its keys once, in a visit() member:
//
//   struct ExternalOptions {
//     double tau = 1.0;
//     template <class V> void visit(V& v) {
//       v(tau, Key{"tau", "mm per unit force", "step of the external force", Range::greater_than(0)});
//     }
//     void check() const {}  // cross-key rules, if any: throw OptionError{"key", "message"}
//   };
//
// and from that one list come reading (read_options: types, enum names, ranges, unknown keys),
// validation (validate_options: the ranges, then check(); constructors call it), the JSON
// Schema of the experiment file and the key tables of docs/experiment-file.md
// (framework/core/options_schema.h). Enums read and print through one name table each (EnumNames).
#pragma once

#include "framework/core/json_reader.h"

#include <array>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace dsnake {

// The admissible values of a numeric key; ends may be open, closed or absent (infinite).
struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false, max_open = false;

  static Range any() { return {}; }
  static Range at_least(double a) { return {a, std::numeric_limits<double>::infinity(), false, false}; }
  static Range greater_than(double a) { return {a, std::numeric_limits<double>::infinity(), true, false}; }
  static Range closed(double a, double b) { return {a, b, false, false}; }
  static Range open_closed(double a, double b) { return {a, b, true, false}; }  // (a, b]
  static Range closed_open(double a, double b) { return {a, b, false, true}; }  // [a, b)
  static Range open(double a, double b) { return {a, b, true, true}; }

  bool bounded_below() const { return min > -std::numeric_limits<double>::infinity(); }
  bool bounded_above() const { return max < std::numeric_limits<double>::infinity(); }
  bool contains(double x) const;
  // "must be >= 0", "must be in (0, 1]"; "" for any().
  std::string requirement() const;
  // "[0, inf)", "(0, 1]"; "any" for any().
  std::string text() const;
};

// One key of an options struct: its JSON name, its unit ("" for a pure number), what it means
// and, for numbers, its range.
struct Key {
  const char* name;
  const char* unit;
  const char* help;
  Range range = {};
};

// A broken rule of an options struct: the key at fault and what is wrong ("must be > 0").
struct OptionError {
  std::string key, message;
};

// The name table of an enum: specialise with
//   template <> struct EnumNames<Kind> { static constexpr std::array<std::pair<Kind, const char*>, 2>
//     table{{{Kind::kA, "a"}, {Kind::kB, "b"}}}; };
template <class E>
struct EnumNames;

template <class E>
concept NamedEnum = requires { EnumNames<E>::table; };

template <NamedEnum E>
const char* enum_name(E value) {
  for (const auto& [v, n] : EnumNames<E>::table)
    if (v == value) return n;
  return "?";
}

template <NamedEnum E>
std::optional<E> enum_from_name(std::string_view name) {
  for (const auto& [v, n] : EnumNames<E>::table)
    if (name == n) return v;
  return std::nullopt;
}

// "\"a\", \"b\" or \"c\"".
template <NamedEnum E>
std::string enum_choices() {
  std::string s;
  const size_t n = EnumNames<E>::table.size();
  for (size_t i = 0; i < n; ++i)
    s += (i == 0 ? "" : i + 1 == n ? " or " : ", ") + std::string("\"") + EnumNames<E>::table[i].second + "\"";
  return s;
}

namespace options_detail {

template <class T>
struct IsOptional : std::false_type {};
template <class T>
struct IsOptional<std::optional<T>> : std::true_type {};

template <class O>
concept HasCheck = requires(const O& o) { o.check(); };

// Points of D numbers (Point<D>, key "center": [x, y(, z)]) and lists of them.
template <class T>
struct IsPoint : std::false_type {};
template <int D>
struct IsPoint<Point<D>> : std::true_type {
  static constexpr int kDim = D;
};

// Reads every key the options list from a JsonReader (types and enum names checked here;
// ranges in validate_options).
class ReadVisitor {
 public:
  explicit ReadVisitor(JsonReader& reader) : reader_(reader) {}
  template <class T>
  void operator()(T& value, const Key& key) {
    if constexpr (IsOptional<T>::value) {  // absent: no value
      if (!reader_.has(key.name)) return;
      typename T::value_type x{};
      (*this)(x, key);
      value = x;
    } else if constexpr (NamedEnum<T>) {
      if (!reader_.has(key.name)) return;
      std::string name;
      reader_.read(key.name, name);
      const auto v = enum_from_name<T>(name);
      if (!v) reader_.fail(key.name, "must be " + enum_choices<T>() + ", found \"" + name + "\"");
      value = *v;
    } else if constexpr (IsPoint<T>::value) {
      reader_.template read<IsPoint<T>::kDim>(key.name, value);
    } else {
      reader_.read(key.name, value);
    }
  }

 private:
  JsonReader& reader_;
};

// Throws OptionError for the first numeric key outside its range.
struct RangeVisitor {
  template <class T>
  void operator()(const T& value, const Key& key) const {
    if constexpr (IsOptional<T>::value) {
      if (value) (*this)(*value, key);
    } else if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      if (!key.range.contains(static_cast<double>(value))) throw OptionError{key.name, key.range.requirement()};
    } else if constexpr (IsPoint<T>::value) {  // the range holds for every coordinate
      for (int a = 0; a < IsPoint<T>::kDim; ++a)
        if (!key.range.contains(value[a])) throw OptionError{key.name, key.range.requirement()};
    }
  }
};

}  // namespace options_detail

// Checks the ranges of every key, then the struct's own cross-key rules (check()). Throws
// OptionError; constructors of plug-ins call it, so that a programmatic caller is held to the
// same rules as an experiment file.
template <class O>
void validate_options(const O& options) {
  options_detail::RangeVisitor v;
  const_cast<O&>(options).visit(v);  // RangeVisitor only reads
  if constexpr (options_detail::HasCheck<O>) options.check();
}

// Reads the options from `reader` (keys left absent keep their defaults), validates them and
// turns a broken rule into an InputError naming the file and the JSON path. Does not call
// reader.finish(): the caller may read keys of its own (a registry's "type", "weight").
template <class O>
void read_options(JsonReader& reader, O& options) {
  options_detail::ReadVisitor v(reader);
  options.visit(v);
  try {
    validate_options(options);
  } catch (const OptionError& e) {
    reader.fail(e.key, e.message);
  }
}

// As read_options, starting from the defaults.
template <class O>
O read_options(JsonReader& reader) {
  O options;
  read_options(reader, options);
  return options;
}

// For constructors: validates and turns a broken rule into a programmer error (the experiment
// reader has already reported it with its JSON path if it came from a file).
void throw_invalid_options(const char* type, const OptionError& error);
template <class O>
const O& checked(const O& options, const char* type) {
  try {
    validate_options(options);
  } catch (const OptionError& e) {
    throw_invalid_options(type, e);
  }
  return options;
}

}  // namespace dsnake
