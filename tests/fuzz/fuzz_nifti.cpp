// libFuzzer target: the NIfTI reader (framework/io/nifti.cpp, NIfTI-1 and NIfTI-2); gzip input
// (magic 1f 8b) is read as .nii.gz, anything else as .nii; then the same bytes as both files of a
// .hdr/.img pair (gzipped: .hdr.gz/.img.gz), the header read from the .hdr and the values from the
// .img at vox_offset.
#include "tests/fuzz/fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake::fuzz;
  const bool gz = starts_with(data, size, "\x1f\x8b");
  read_image_file(data, size, gz ? "image.nii.gz" : "image.nii");
  write_input(data, size, gz ? "pair.img.gz" : "pair.img");
  read_image_file(data, size, gz ? "pair.hdr.gz" : "pair.hdr");
  return 0;
}
