// Reading JSON input files safely; see json_text.h.
#include "framework/core/json_text.h"

#include "framework/core/errors.h"

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

namespace dsnake {

namespace fs = std::filesystem;

namespace {

// nlohmann's message without its "[json.exception.x.y] " prefix.
std::string clean(const std::string& what) {
  const auto p = what.find("] ");
  return p == std::string::npos ? what : what.substr(p + 2);
}

// One open object or array while parsing: where a value sits (for the path of an error) and an
// object's keys so far.
struct OpenValue {
  bool array = false;
  int64_t index = -1;      // an array's current element
  std::string key;         // an object's current key
  std::set<std::string> keys;
};

// The JSON path of the innermost open value's current member: energies[2].weight.
std::string path_of(const std::vector<OpenValue>& open) {
  std::string path;
  for (const OpenValue& v : open) {
    if (v.array) path += "[" + std::to_string(v.index) + "]";
    else path += (path.empty() ? "" : ".") + v.key;
  }
  return path;
}

template <class Json>
Json parse_bounded(const std::string& text, const std::string& file) {
  using Event = typename Json::parse_event_t;
  std::vector<OpenValue> open;
  // The callback sees every value's depth as it is parsed: deeper than the bound stops the parse
  // before the value exists. It also refuses a key that its object already has: RFC 8259 leaves
  // which one counts to the reader (nlohmann keeps the last), so a file that says "seed" twice
  // would run with a value its author may not have meant.
  auto bounded = [&](int depth, Event event, Json& parsed) {
    if (depth > kMaxJsonDepth && (event == Event::object_start || event == Event::array_start))
      throw InputError(file, "", "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    switch (event) {
      case Event::object_start:
      case Event::array_start:
        if (!open.empty() && open.back().array) ++open.back().index;
        open.push_back({event == Event::array_start, -1, {}, {}});
        break;
      case Event::object_end:
      case Event::array_end:
        if (!open.empty()) open.pop_back();
        break;
      case Event::key:
        if (!open.empty() && parsed.is_string()) {
          OpenValue& object = open.back();
          object.key = parsed.template get<std::string>();
          if (!object.keys.insert(object.key).second)
            throw InputError(file, path_of(open), "the key appears twice in its object (JSON leaves which one counts undefined)");
        }
        break;
      case Event::value:
        if (!open.empty() && open.back().array) ++open.back().index;
        break;
    }
    return true;
  };
  try {
    return Json::parse(text, bounded, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(file, "", "JSON syntax error: " + clean(e.what()));
  } catch (const nlohmann::json::out_of_range& e) {  // "1e999": found by fuzzing
    throw InputError(file, "", "JSON number out of range: " + clean(e.what()));
  }
}

}  // namespace

void require_regular_file(const std::string& path, const std::string& what) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) throw InputError(path, "", "file not found");
  if (fs::is_directory(st)) throw InputError(path, "", "expected the " + what + ", found a folder");
  if (!fs::is_regular_file(st)) throw InputError(path, "", "expected the " + what + ", found a pipe or a device (not read)");
}

std::string read_input_text(const std::string& path, const std::string& what, std::uintmax_t max_bytes) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "", "no such " + what);
  require_regular_file(path, what);
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

bool is_valid_utf8(const std::string& text) {
  const auto* p = reinterpret_cast<const unsigned char*>(text.data());
  const size_t n = text.size();
  for (size_t i = 0; i < n;) {
    const unsigned c = p[i];
    int extra = 0;
    unsigned min = 0, cp = 0;
    if (c < 0x80) { ++i; continue; }
    if ((c & 0xE0) == 0xC0) { extra = 1; min = 0x80; cp = c & 0x1F; }
    else if ((c & 0xF0) == 0xE0) { extra = 2; min = 0x800; cp = c & 0x0F; }
    else if ((c & 0xF8) == 0xF0) { extra = 3; min = 0x10000; cp = c & 0x07; }
    else return false;
    for (int k = 1; k <= extra; ++k) {
      if (i + size_t(k) >= n || (p[i + size_t(k)] & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (p[i + size_t(k)] & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += size_t(extra) + 1;
  }
  return true;
}

nlohmann::json parse_json_text(const std::string& text, const std::string& file) {
  return parse_bounded<nlohmann::json>(text, file);
}

nlohmann::ordered_json parse_ordered_json_text(const std::string& text, const std::string& file) {
  return parse_bounded<nlohmann::ordered_json>(text, file);
}

}  // namespace dsnake
