// Shared by the libFuzzer targets. Each target writes the fuzzer's bytes to a file
// whose name gives the reader its format, runs the reader as `dsnake` would, and holds it to the
// command line's contract: the only acceptable failure is an InputError, whose message is one
// line of bounded length (main.cpp prints it and exits 2). Anything else (another exception, a
// sanitizer report, a crash, an allocation past libFuzzer's -rss_limit_mb) is a finding.
// fuzz_support.cpp also defines every target's LLVMFuzzerInitialize: a memory limit for the image
// readers (DSNAKE_MAX_IMAGE_BYTES, 256 MB), so that a header declaring a large but legal image is
// refused instead of filling libFuzzer's RSS limit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace dsnake::fuzz {

// Writes the input to "<private folder>/<name>" and returns the path. The folder is made once
// per process under $TMPDIR (or /tmp) and removed at exit.
std::string write_input(const uint8_t* data, size_t size, const std::string& name);

// Runs `reader`; returns normally when it succeeds or throws an InputError that keeps the
// one-line contract, aborts (a libFuzzer finding) otherwise.
void expect_input_errors_only(const std::function<void()>& reader);

// True if the bytes begin with `magic`.
bool starts_with(const uint8_t* data, size_t size, const std::string& magic);

}  // namespace dsnake::fuzz
