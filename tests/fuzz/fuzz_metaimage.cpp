// libFuzzer target: the MetaImage reader (.mha: the text header, then raw or zlib data
// in the same file; framework/io/metaimage.cpp).
#include "tests/fuzz/fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake::fuzz;
  read_image_file(data, size, "image.mha");
  return 0;
}
