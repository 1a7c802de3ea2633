#include "framework/core/options.h"

#include "framework/core/errors.h"
#include "framework/core/options_schema.h"

#include <cmath>
#include <sstream>

namespace dsnake {

namespace {

std::string number_text(double x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  std::ostringstream s;
  s << x;
  return s.str();
}

}  // namespace

bool Range::contains(double x) const {
  if (std::isnan(x)) return false;
  if (min_open ? !(x > min) : !(x >= min)) return false;
  if (max_open ? !(x < max) : !(x <= max)) return false;
  return true;
}

std::string Range::requirement() const {
  if (!bounded_below() && !bounded_above()) return "";
  if (!bounded_above()) return std::string("must be ") + (min_open ? "> " : ">= ") + number_text(min);
  if (!bounded_below()) return std::string("must be ") + (max_open ? "< " : "<= ") + number_text(max);
  return "must be in " + text();
}

std::string Range::text() const {
  if (!bounded_below() && !bounded_above()) return "any";
  return std::string(min_open || !bounded_below() ? "(" : "[") + number_text(min) + ", " + number_text(max) +
         (max_open || !bounded_above() ? ")" : "]");
}

void throw_invalid_options(const char* type, const OptionError& error) {
  DSNAKE_ASSERT(false, std::string(type) + " options: " + error.key + " " + error.message);
}

std::string key_table_markdown(const std::vector<KeyRow>& rows) {
  if (rows.empty()) return "No options.\n";
  std::string s = "| key | type | unit | default | range | meaning |\n| --- | --- | --- | --- | --- | --- |\n";
  auto cell = [](std::string t) {
    for (size_t p = 0; (p = t.find('|', p)) != std::string::npos; p += 2) t.replace(p, 1, "\\|");
    return t;
  };
  for (const auto& r : rows)
    s += "| `" + r.name + "` | " + cell(r.type) + " | " + cell(r.unit.empty() ? "-" : r.unit) + " | `" +
         cell(r.default_value) + "` | " + cell(r.range.empty() ? "-" : r.range) + " | " + cell(r.help) + " |\n";
  return s;
}

}  // namespace dsnake
