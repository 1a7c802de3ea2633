// libFuzzer target: the 2D contour readers (framework/io/mesh_io.cpp): JSON
// ({"points", "landmarks"}) when the input begins with '{', a VTK polyline when it begins with
// "# vtk", the text format otherwise.
#include "framework/io/mesh_io.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake;
  const char* name = fuzz::starts_with(data, size, "{")       ? "contour.json"
                     : fuzz::starts_with(data, size, "# vtk") ? "contour.vtk"
                                                              : "contour.txt";
  const std::string path = fuzz::write_input(data, size, name);
  fuzz::expect_input_errors_only([&] { read_contour_template(path); });
  return 0;
}
