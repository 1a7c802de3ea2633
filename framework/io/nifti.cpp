// NIfTI-1 (.nii/.nii.gz) reading and writing; see image_io.h.
#include "framework/io/image_io_detail.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake::detail {

namespace fs = std::filesystem;


constexpr size_t kNiftiVoxOffset = 352;

// A field of a NIfTI-1 header at byte `offset`, in the file's byte order.
template <class T>
T nifti_field(const std::string& h, size_t offset, bool swap) {
  return static_cast<T>(load<T>(h.data() + offset, swap));
}

// Stores a header field in native (little-endian) order.
template <class T>
void put(std::string& h, size_t offset, T value) {
  std::memcpy(h.data() + offset, &value, sizeof(T));
}

// Decodes a NIfTI-1 header (and, unless header_only, the data) from its bytes.
RawVolume decode_nifti(const std::string& bytes, const std::string& path, bool header_only) {
  if (bytes.size() < kNiftiHeaderBytes)
    throw InputError(path, "header", "unreadable header: file holds " + std::to_string(bytes.size()) +
                                         " bytes, a NIfTI-1 header needs 348");
  const int32_t sizeof_hdr = nifti_field<int32_t>(bytes, 0, false);
  bool swap = false;
  if (sizeof_hdr != 348) {
    if (nifti_field<int32_t>(bytes, 0, true) != 348)
      throw InputError(path, "sizeof_hdr", "not a NIfTI-1 file (sizeof_hdr = " + std::to_string(sizeof_hdr) + ")");
    swap = true;
  }
  if (std::memcmp(bytes.data() + 344, "n+1", 4) != 0)
    throw InputError(path, "magic", "only single-file NIfTI-1 (magic \"n+1\") is supported");
  RawVolume v;
  v.dim_key = "dim";
  v.spacing_key = "pixdim";
  v.channel_key = "dim[5]";
  std::array<int, 8> dim;
  for (int i = 0; i < 8; ++i) dim[i] = nifti_field<int16_t>(bytes, 40 + 2 * i, swap);
  if (dim[0] < 2 || dim[0] > 5)
    throw InputError(path, "dim", "unsupported dimension " + std::to_string(dim[0]) + " (expected 2 or 3)");
  for (int i = 1; i <= dim[0]; ++i)
    if (dim[i] < 1) throw InputError(path, "dim", "dim[" + std::to_string(i) + "] = " + std::to_string(dim[i]) + " is not positive");
  if (dim[0] >= 4 && dim[4] != 1) throw InputError(path, "dim", "time series (dim[4] > 1) are not supported");
  v.ndims = dim[0] == 2 ? 2 : 3;
  for (int a = 0; a < v.ndims; ++a) v.size[a] = dim[a + 1];
  v.channels = dim[0] == 5 ? dim[5] : 1;
  for (int a = 0; a < 3; ++a) v.spacing[a] = nifti_field<float>(bytes, 76 + 4 * (a + 1), swap);
  // Origin and axis directions from the qform (preferred, as before) or the sform; the numbers
  // are the file's own (NIfTI's RAS). read_volume aligns the axes with the world's.
  if (nifti_field<int16_t>(bytes, 252, swap) > 0) {
    for (int a = 0; a < 3; ++a) v.origin[a] = nifti_field<float>(bytes, 268 + 4 * a, swap);
    const double b = nifti_field<float>(bytes, 256, swap), c = nifti_field<float>(bytes, 260, swap),
                 d = nifti_field<float>(bytes, 264, swap);
    const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
    const double qfac = nifti_field<float>(bytes, 76, swap) < 0 ? -1.0 : 1.0;
    const double r[3][3] = {{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
                            {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
                            {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - b * b - c * c}};
    for (int axis = 0; axis < 3; ++axis)
      for (int k = 0; k < 3; ++k) v.axes[axis][k] = r[k][axis] * (axis == 2 ? qfac : 1.0);
  } else if (nifti_field<int16_t>(bytes, 254, swap) > 0) {
    for (int a = 0; a < 3; ++a) v.origin[a] = nifti_field<float>(bytes, 280 + 16 * a + 12, swap);
    for (int axis = 0; axis < 3; ++axis) {
      double column[3], norm = 0;
      for (int k = 0; k < 3; ++k) {
        column[k] = nifti_field<float>(bytes, 280 + 16 * k + 4 * axis, swap);
        norm += column[k] * column[k];
      }
      norm = std::sqrt(norm);
      if (norm > 0)
        for (int k = 0; k < 3; ++k) v.axes[axis][k] = column[k] / norm;
    }
  }
  if (header_only) return v;

  const int16_t datatype = nifti_field<int16_t>(bytes, 70, swap);
  static const std::map<int, Scalar> types = {{2, Scalar::kU8},    {4, Scalar::kI16},   {8, Scalar::kI32},
                                              {16, Scalar::kF32},  {64, Scalar::kF64},  {256, Scalar::kI8},
                                              {512, Scalar::kU16}, {768, Scalar::kU32}};
  auto type_it = types.find(datatype);
  if (type_it == types.end()) throw InputError(path, "datatype", "unsupported datatype " + std::to_string(datatype));
  const float vox_offset = nifti_field<float>(bytes, 108, swap);
  if (!(vox_offset >= 0) || vox_offset > float(bytes.size()))
    throw InputError(path, "vox_offset", "data offset " + exact(vox_offset) + " lies outside the file");
  const int64_t count = v.num_voxels() * v.channels;
  const size_t expected = size_t(count) * scalar_bytes(type_it->second);
  const size_t available = bytes.size() - size_t(vox_offset);
  if (available < expected)
    throw InputError(path, "vox_offset", "data holds " + std::to_string(available) + " bytes, expected " +
                                             std::to_string(expected));
  const std::vector<double> stored = decode(bytes.data() + size_t(vox_offset), count, type_it->second, swap);
  const double slope = nifti_field<float>(bytes, 112, swap), inter = nifti_field<float>(bytes, 116, swap);
  const bool scaled = slope != 0 && std::isfinite(slope) && std::isfinite(inter);
  // NIfTI keeps components slowest (one volume per component); RawVolume interleaves them.
  const int64_t n = v.num_voxels();
  v.values.resize(count);
  for (int c = 0; c < v.channels; ++c)
    for (int64_t i = 0; i < n; ++i) {
      const double s = stored[c * n + i];
      v.values[i * v.channels + c] = scaled ? s * slope + inter : s;
    }
  return v;
}

// Writes a float32 NIfTI-1 (.nii, or gzipped .nii.gz), origin in qoffset with qform_code 1.
void write_nifti(const RawVolume& v, const std::string& path) {
  std::string h(kNiftiVoxOffset, '\0');
  put<int32_t>(h, 0, 348);
  std::array<int16_t, 8> dim{};
  dim.fill(1);
  dim[0] = int16_t(v.channels > 1 ? 5 : v.ndims);
  for (int a = 0; a < 3; ++a) dim[a + 1] = int16_t(a < v.ndims ? v.size[a] : 1);
  dim[5] = int16_t(v.channels);
  for (int i = 0; i < 8; ++i) put<int16_t>(h, 40 + 2 * i, dim[i]);
  if (v.channels > 1) put<int16_t>(h, 68, 1007);  // NIFTI_INTENT_VECTOR
  put<int16_t>(h, 70, 16);                         // float32
  put<int16_t>(h, 72, 32);
  put<float>(h, 76, 1.0f);  // qfac
  for (int a = 0; a < 3; ++a) put<float>(h, 80 + 4 * a, float(a < v.ndims ? v.spacing[a] : 1.0));
  for (int i = 4; i < 8; ++i) put<float>(h, 76 + 4 * i, 1.0f);
  put<float>(h, 108, float(kNiftiVoxOffset));
  put<float>(h, 112, 1.0f);  // scl_slope
  put<int8_t>(h, 123, 2);    // xyzt_units: mm
  put<int16_t>(h, 252, 1);   // qform_code; quaternion b = c = d = 0 is the identity
  for (int a = 0; a < 3; ++a) put<float>(h, 268 + 4 * a, float(v.origin[a]));
  std::memcpy(h.data() + 344, "n+1", 4);
  const int64_t n = v.num_voxels();
  std::vector<double> planar(v.values.size());
  for (int c = 0; c < v.channels; ++c)
    for (int64_t i = 0; i < n; ++i) planar[c * n + i] = v.values[i * v.channels + c];
  const std::string bytes = h + float_bytes(planar);
  if (extension_of(path) == ".nii") {
    write_file_atomically(path, bytes);
    return;
  }
  write_via_temporary(path, [&](const std::string& tmp) {
    gzFile f = gzopen(tmp.c_str(), "wb");
    if (!f) throw std::runtime_error(path + ": cannot open for writing");
    const int written = gzwrite(f, bytes.data(), static_cast<unsigned>(bytes.size()));
    if (gzclose(f) != Z_OK || written != int(bytes.size())) throw std::runtime_error(path + ": write failed");
  });
}

}  // namespace dsnake::detail
