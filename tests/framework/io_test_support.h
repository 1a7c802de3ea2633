// Helpers the I/O tests of tests/framework/ share: a fresh folder per test, whole-file reading
// and writing, and catching the InputError a bad file must give.
#pragma once

#include "framework/core/errors.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <unistd.h>

namespace dsnake::test_support {

// A fresh empty folder for the running test: <tmp>/dsnake_io_<pid>/<suite>_<test>.
inline std::filesystem::path fresh_path() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("dsnake_io_" + std::to_string(::getpid())) /
                                    (std::string(info->test_suite_name()) + "_" + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}
inline std::string fresh_dir() { return fresh_path().string(); }

// The whole file as bytes ("" if it cannot be read).
inline std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

// Runs f, expects an InputError, and returns it for checking its parts.
inline InputError expect_input_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "expected an InputError";
  return InputError("", "", "");
}

inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A bad file must throw an InputError that names it and the field at fault (and, if given,
// says `words` in its message).
template <class Read>
void expect_bad_file(const Read& read, const std::string& path, const std::string& field, const std::string& words) {
  SCOPED_TRACE(path);
  const InputError e = expect_input_error([&] { read(path); });
  EXPECT_EQ(e.file(), path);
  EXPECT_EQ(e.where(), field) << e.what();
  if (!words.empty()) {
    EXPECT_TRUE(contains(e.message(), words)) << e.what();
  }
}

}  // namespace dsnake::test_support
