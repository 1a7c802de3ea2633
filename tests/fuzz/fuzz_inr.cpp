// libFuzzer target: the INRIMAGE-4 reader (framework/io/inr.cpp); gzip input (magic 1f 8b) is
// read as .inr.gz, anything else as .inr.
#include "tests/fuzz/fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake::fuzz;
  read_image_file(data, size, starts_with(data, size, "\x1f\x8b") ? "image.inr.gz" : "image.inr");
  return 0;
}
