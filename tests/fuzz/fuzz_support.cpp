#include "tests/fuzz/fuzz_support.h"

#include "framework/core/errors.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace dsnake::fuzz {

namespace fs = std::filesystem;

namespace {

// The longest message main.cpp may print: errors.cpp cuts each of its three parts at 300
// characters, and the prefix adds a few more.
constexpr size_t kMaxMessageBytes = 1000;

const fs::path& private_folder() {
  static const fs::path folder = [] {
    const char* tmp = std::getenv("TMPDIR");
    fs::path f = fs::path(tmp && *tmp ? tmp : "/tmp") / ("dsnake-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(f);
    std::atexit([] { std::error_code ec; fs::remove_all(private_folder(), ec); });
    return f;
  }();
  return folder;
}

}  // namespace

std::string write_input(const uint8_t* data, size_t size, const std::string& name) {
  const fs::path path = private_folder() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
  return path.string();
}

void expect_input_errors_only(const std::function<void()>& reader) {
  try {
    reader();
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.find('\n') != std::string::npos || what.find('\r') != std::string::npos || what.size() > kMaxMessageBytes) {
      std::fprintf(stderr, "fuzz: an InputError that is not one short line (%zu bytes): %.2000s\n", what.size(), what.c_str());
      std::abort();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: not an InputError (dsnake would exit 1): %.2000s\n", e.what());
    std::abort();
  }
}

bool starts_with(const uint8_t* data, size_t size, const std::string& magic) {
  return size >= magic.size() && std::equal(magic.begin(), magic.end(), reinterpret_cast<const char*>(data));
}

}  // namespace dsnake::fuzz

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  ::setenv("DSNAKE_MAX_IMAGE_BYTES", "268435456", /*overwrite=*/0);
  return 0;
}
