// libFuzzer target: 2D raster images through OpenCV (PNG, JPEG, BMP, TIFF), named by their
// magic bytes so that the extension matches the content as a user's file would.
#include "tests/fuzz/fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake::fuzz;
  const char* name = starts_with(data, size, "\xff\xd8") ? "image.jpg"
                     : starts_with(data, size, "BM")       ? "image.bmp"
                     : starts_with(data, size, "II*") || starts_with(data, size, "MM") ? "image.tif"
                                                           : "image.png";
  read_image_file(data, size, name);
  return 0;
}
