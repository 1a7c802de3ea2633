// Error types. Bad user input (config, image, mesh) is an InputError that names the file and
// the JSON path or element; the CLI turns it into one line on stderr and exit code 2.
// Programmer errors are DSNAKE_ASSERT failures (std::logic_error, exit code 1).
#pragma once

#include <stdexcept>
#include <string>

namespace dsnake {

class InputError : public std::runtime_error {
 public:
  // file: the file at fault ("" for the command line); where: a JSON path such as
  // "energies[1].alpha" or an element such as "vertex 12"; message: what is wrong.
  InputError(std::string file, std::string where, std::string message);

  const std::string& file() const { return file_; }
  const std::string& where() const { return where_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_, where_, message_;
};

[[noreturn]] void assertion_failed(const char* expr, const char* file, int line, const std::string& msg);

}  // namespace dsnake

// Internal invariant check, active in every build type; says where it failed.
#define DSNAKE_ASSERT(cond, msg) \
  do { if (!(cond)) ::dsnake::assertion_failed(#cond, __FILE__, __LINE__, (msg)); } while (0)
