// Reading JSON input files safely; see json_text.h.
#include "framework/core/json_text.h"

#include "framework/core/errors.h"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake {

namespace fs = std::filesystem;

namespace {

// nlohmann's message without its "[json.exception.x.y] " prefix.
std::string clean(const std::string& what) {
  const auto p = what.find("] ");
  return p == std::string::npos ? what : what.substr(p + 2);
}

template <class Json>
Json parse_bounded(const std::string& text, const std::string& file) {
  // The callback sees every value's depth as it is parsed: deeper than the bound stops the parse
  // before the value exists.
  auto bounded = [&](int depth, typename Json::parse_event_t event, Json&) {
    if (depth > kMaxJsonDepth && (event == Json::parse_event_t::object_start || event == Json::parse_event_t::array_start))
      throw InputError(file, "", "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    return true;
  };
  try {
    return Json::parse(text, bounded, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(file, "", "JSON syntax error: " + clean(e.what()));
  }
}

}  // namespace

std::string read_input_text(const std::string& path, const std::string& what, std::uintmax_t max_bytes) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) throw InputError(path, "", "no such " + what);
  if (fs::is_directory(st)) throw InputError(path, "", "expected the " + what + ", found a folder");
  if (!fs::is_regular_file(st)) throw InputError(path, "", "expected the " + what + ", found a pipe or a device (not read)");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw InputError(path, "", "cannot read " + what + ": " + ec.message());
  if (size > max_bytes)
    throw InputError(path, "", what + " of " + std::to_string(size) + " bytes is larger than " + std::to_string(max_bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot read " + what);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

nlohmann::json parse_json_text(const std::string& text, const std::string& file) {
  return parse_bounded<nlohmann::json>(text, file);
}

nlohmann::ordered_json parse_ordered_json_text(const std::string& text, const std::string& file) {
  return parse_bounded<nlohmann::ordered_json>(text, file);
}

}  // namespace dsnake
