#include "framework/core/atomic_file.h"

#include <cerrno>
#include <cstring>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

namespace dsnake {

namespace fs = std::filesystem;

// One line: a library's reason (OpenCV's exceptions) may span several.
static std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

OutputError::OutputError(const std::string& file, const std::string& reason)
    : std::runtime_error(one_line(file + ": cannot write (" + reason + ")")) {}

// The system's reason for the last failed call (strerror(errno)), or `fallback` when errno is 0.
static std::string system_reason(const std::string& fallback) {
  return errno != 0 ? std::string(std::strerror(errno)) : fallback;
}

static std::string temporary_name(const std::string& path) {
  static std::atomic<int> counter{0};
  const fs::path p(path);
  const std::string name = ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-" +
                           p.filename().string();
  return (p.parent_path() / name).string();
}

void write_via_temporary(const std::string& path, const std::function<void(const std::string&)>& write) {
  const std::string tmp = temporary_name(path);
  try {
    write(tmp);
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) throw OutputError(path, ec.message());
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  write_file_atomically(path, std::vector<std::string_view>{bytes});
}

void write_file_atomically(const std::string& path, const std::vector<std::string_view>& parts) {
  write_stream_atomically(path, [&](const std::function<void(std::string_view)>& put) {
    for (const std::string_view part : parts) put(part);
  });
}

void write_stream_atomically(const std::string& path,
                             const std::function<void(const std::function<void(std::string_view)>& put)>& produce) {
  write_via_temporary(path, [&](const std::string& tmp) {
    errno = 0;
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw OutputError(path, system_reason("cannot open for writing"));
    produce([&](std::string_view piece) {
      out.write(piece.data(), static_cast<std::streamsize>(piece.size()));
      if (!out) throw OutputError(path, system_reason("write failed"));  // a full disk: stop at once
    });
    out.close();
    if (!out) throw OutputError(path, system_reason("write failed"));  // a full disk: ENOSPC
  });
}

}  // namespace dsnake
