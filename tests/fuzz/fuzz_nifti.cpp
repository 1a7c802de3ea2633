// libFuzzer target: the NIfTI-1 reader (framework/io/nifti.cpp); gzip input (magic 1f 8b)
// is read as .nii.gz, anything else as .nii.
#include "tests/fuzz/fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake::fuzz;
  read_image_file(data, size, starts_with(data, size, "\x1f\x8b") ? "image.nii.gz" : "image.nii");
  return 0;
}
