// libFuzzer target: the 3D mesh readers (OpenMesh for OFF, OBJ, PLY and STL; ours for
// legacy VTK; then the template checks: closed, manifold, one orientation). The extension follows
// the content as a user's file would: "ply", "OFF", "# vtk" and "solid" name their formats, a
// line starting "v ", "f ", "o " or "#" is OBJ, anything else binary STL.
#include "framework/io/mesh_io.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake;
  using fuzz::starts_with;
  const char* name = starts_with(data, size, "ply")      ? "mesh.ply"
                     : starts_with(data, size, "OFF")    ? "mesh.off"
                     : starts_with(data, size, "# vtk")  ? "mesh.vtk"
                     : starts_with(data, size, "solid")  ? "mesh.stl"
                     : starts_with(data, size, "v ") || starts_with(data, size, "f ") || starts_with(data, size, "o ") ||
                             starts_with(data, size, "#")
                         ? "mesh.obj"
                         : "mesh.stl";
  const std::string path = fuzz::write_input(data, size, name);
  fuzz::expect_input_errors_only([&] { read_mesh_template(path); });
  return 0;
}
