// Reading JSON input files safely: the file must be a regular file of bounded size
// (a folder, a FIFO or a device is refused at once rather than read or waited on), and its
// nesting is bounded, since nlohmann's values are copied and compared recursively: 100 000
// nested objects overflowed the stack. Every problem is one InputError naming the file.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace dsnake {

inline constexpr int kMaxJsonDepth = 64;                          // objects and arrays inside each other
inline constexpr std::uintmax_t kMaxJsonFileBytes = std::uintmax_t(64) << 20;  // 64 MB

// InputError unless `path` is a regular file: "file not found", "expected the <what>, found a
// folder", or "... found a pipe or a device (not read)" (a FIFO is never opened, so never waited on).
void require_regular_file(const std::string& path, const std::string& what);

// The bytes of `path`, a regular file of at most max_bytes; `what` names it in errors ("the
// experiment file").
std::string read_input_text(const std::string& path, const std::string& what, std::uintmax_t max_bytes = kMaxJsonFileBytes);

// True if `text` is well-formed UTF-8 (no overlong forms, surrogates or code points past
// U+10FFFF). JSON strings must be: nlohmann's dump() throws on anything else.
bool is_valid_utf8(const std::string& text);

// Parses JSON (comments allowed) with at most kMaxJsonDepth levels; `file` names the text in errors.
nlohmann::json parse_json_text(const std::string& text, const std::string& file);
nlohmann::ordered_json parse_ordered_json_text(const std::string& text, const std::string& file);

}  // namespace dsnake
