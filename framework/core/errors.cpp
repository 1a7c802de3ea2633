#include "framework/core/errors.h"

namespace dsnake {

// One part of an error line: line breaks become spaces, and a part longer than kMaxPart
// characters (a 50 MB string value) is cut, saying how long it was (an error is one short line).
static std::string one_line(const std::string& part) {
  constexpr size_t kMaxPart = 300;
  std::string s = part.size() > kMaxPart ? part.substr(0, kMaxPart) + "... (" + std::to_string(part.size()) + " characters)" : part;
  for (char& c : s) {
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
    else if ((c >= 0 && c < 0x20) || c == 0x7f) c = '?';  // a binary file's bytes: no terminal control codes
  }
  return s;
}

static std::string compose(const std::string& file, const std::string& where, const std::string& message) {
  std::string s;
  if (!file.empty()) s += one_line(file);
  if (!where.empty()) s += (s.empty() ? "" : ": ") + one_line(where);
  return s + (s.empty() ? "" : ": ") + one_line(message);
}

InputError::InputError(std::string file, std::string where, std::string message)
    : std::runtime_error(compose(file, where, message)),
      file_(std::move(file)), where_(std::move(where)), message_(std::move(message)) {}

void assertion_failed(const char* expr, const char* file, int line, const std::string& msg) {
  throw std::logic_error(std::string("internal error at ") + file + ":" + std::to_string(line) +
                         ": " + expr + (msg.empty() ? "" : " (" + msg + ")"));
}

}  // namespace dsnake
