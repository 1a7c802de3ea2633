// libFuzzer target: the NRRD reader (framework/io/nrrd.cpp): the header's fields, raw or gzip
// data attached to the header.
#include "tests/fuzz/fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake::fuzz;
  read_image_file(data, size, "image.nrrd");
  return 0;
}
