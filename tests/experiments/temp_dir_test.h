// A GoogleTest fixture for tests that write files: a fresh folder per test,
// <tmp>/dsnake_<suite>_<pid>_<test>, removed afterwards, and a helper that reads a file whole;
// and one for tests that run the dsnake binary (DSNAKE_EXE) in that folder.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <cstdlib>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace dsnake::test_support {

class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("dsnake_" + std::string(info->test_suite_name()) + "_" + std::to_string(::getpid()) + "_" + info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  static std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  std::filesystem::path dir_;
};

class CommandTest : public TempDirTest {
 protected:
  // Runs dsnake with `args` (a shell command line's arguments); returns the exit code, and its
  // stdout and stderr in out_ and err_.
  int dsnake(const std::string& args) {
    const std::string o = (dir_ / "stdout.txt").string(), e = (dir_ / "stderr.txt").string();
    const int status = std::system((std::string(DSNAKE_EXE) + " " + args + " >" + o + " 2>" + e).c_str());
    out_ = slurp(o);
    err_ = slurp(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string out_, err_;
};

}  // namespace dsnake::test_support
