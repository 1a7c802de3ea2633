#include "framework/core/errors.h"

namespace dsnake {

static std::string compose(const std::string& file, const std::string& where, const std::string& message) {
  std::string s;
  if (!file.empty()) s += file;
  if (!where.empty()) s += (s.empty() ? "" : ": ") + where;
  return s + (s.empty() ? "" : ": ") + message;
}

InputError::InputError(std::string file, std::string where, std::string message)
    : std::runtime_error(compose(file, where, message)),
      file_(std::move(file)), where_(std::move(where)), message_(std::move(message)) {}

void assertion_failed(const char* expr, const char* file, int line, const std::string& msg) {
  throw std::logic_error(std::string("internal error at ") + file + ":" + std::to_string(line) +
                         ": " + expr + (msg.empty() ? "" : " (" + msg + ")"));
}

}  // namespace dsnake
