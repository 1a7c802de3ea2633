// NIfTI-1 (.nii/.nii.gz) reading and writing; see image_io.h.
#include "framework/io/image_io_detail.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
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

// NIfTI's world is RAS (x to the right, y anterior); dsnake's is LPS: negates the x and y
// components of the origin and of every axis direction (its own inverse, so writing uses it too).
void ras_to_lps(std::array<double, 3>& origin, std::array<std::array<double, 3>, 3>& axes) {
  origin[0] = -origin[0];
  origin[1] = -origin[1];
  for (auto& axis : axes) {
    axis[0] = -axis[0];
    axis[1] = -axis[1];
  }
}
void ras_to_lps(RawVolume& v) { ras_to_lps(v.origin, v.axes); }

// The NIfTI quaternion (b, c, d) and qfac of a 3x3 direction matrix whose columns are the
// axes (NIfTI-1 header comments, "method 2"): a proper rotation has qfac 1; a reflection is
// stored as qfac -1 with the third column negated. Uses the largest of the four squared
// components for a stable division.
std::array<double, 4> quaternion_of(std::array<std::array<double, 3>, 3> axes) {
  const double det = axes[0][0] * (axes[1][1] * axes[2][2] - axes[2][1] * axes[1][2]) -
                     axes[1][0] * (axes[0][1] * axes[2][2] - axes[2][1] * axes[0][2]) +
                     axes[2][0] * (axes[0][1] * axes[1][2] - axes[1][1] * axes[0][2]);
  const double qfac = det < 0 ? -1.0 : 1.0;
  if (qfac < 0)
    for (double& c : axes[2]) c = -c;
  auto r = [&](int row, int col) { return axes[col][row]; };  // r(k, a): world k of axis a
  const double trace = r(0, 0) + r(1, 1) + r(2, 2);
  double a, b, c, d;
  if (trace > 0) {
    a = 0.5 * std::sqrt(1 + trace);
    b = (r(2, 1) - r(1, 2)) / (4 * a);
    c = (r(0, 2) - r(2, 0)) / (4 * a);
    d = (r(1, 0) - r(0, 1)) / (4 * a);
  } else if (r(0, 0) >= r(1, 1) && r(0, 0) >= r(2, 2)) {
    b = 0.5 * std::sqrt(std::max(0.0, 1 + r(0, 0) - r(1, 1) - r(2, 2)));
    a = (r(2, 1) - r(1, 2)) / (4 * b);
    c = (r(0, 1) + r(1, 0)) / (4 * b);
    d = (r(0, 2) + r(2, 0)) / (4 * b);
  } else if (r(1, 1) >= r(2, 2)) {
    c = 0.5 * std::sqrt(std::max(0.0, 1 + r(1, 1) - r(0, 0) - r(2, 2)));
    a = (r(0, 2) - r(2, 0)) / (4 * c);
    b = (r(0, 1) + r(1, 0)) / (4 * c);
    d = (r(1, 2) + r(2, 1)) / (4 * c);
  } else {
    d = 0.5 * std::sqrt(std::max(0.0, 1 + r(2, 2) - r(0, 0) - r(1, 1)));
    a = (r(1, 0) - r(0, 1)) / (4 * d);
    b = (r(0, 2) + r(2, 0)) / (4 * d);
    c = (r(1, 2) + r(2, 1)) / (4 * d);
  }
  if (a < 0) b = -b, c = -c, d = -d;  // NIfTI stores a >= 0 implicitly
  return {b, c, d, qfac};
}

// One of the ways a NIfTI-1 header places its voxels, in NIfTI's RAS: voxel (i, j, k) is at
// origin + sum_a spacing[a] index[a] axes[a].
struct NiftiPlacement {
  std::array<double, 3> origin{0, 0, 0};
  std::array<std::array<double, 3>, 3> axes{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  std::array<double, 3> spacing{1, 1, 1};
  std::array<bool, 3> flat{false, false, false};  // sform: the axis's column is zero or not finite
};

// The header's "method 2": the qform (quaternion b, c, d, qfac in pixdim[0], qoffset), with
// pixdim's spacing.
NiftiPlacement qform_placement(const std::string& bytes, bool swap, const std::array<double, 3>& pixdim) {
  NiftiPlacement p;
  p.spacing = pixdim;
  for (int a = 0; a < 3; ++a) p.origin[a] = nifti_field<float>(bytes, 268 + 4 * a, swap);
  double b = nifti_field<float>(bytes, 256, swap), c = nifti_field<float>(bytes, 260, swap),
         d = nifti_field<float>(bytes, 264, swap);
  // As NIfTI's reference code does: when a^2 = 1 - (b^2 + c^2 + d^2) is below 1e-7 (a half
  // turn, whose float32 (b, c, d) leave a tiny positive rest), a is 0 and (b, c, d) is
  // renormalised; else the rest would tilt the axes by ~0.015 degrees and make a plain axis
  // permutation look oblique.
  double a = 1.0 - (b * b + c * c + d * d);
  if (a < 1e-7) {
    const double norm = std::sqrt(b * b + c * c + d * d);
    if (norm > 0) b /= norm, c /= norm, d /= norm;
    a = 0;
  } else {
    a = std::sqrt(a);
  }
  const double qfac = nifti_field<float>(bytes, 76, swap) < 0 ? -1.0 : 1.0;
  const double r[3][3] = {{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
                          {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
                          {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - b * b - c * c}};
  for (int axis = 0; axis < 3; ++axis)
    for (int k = 0; k < 3; ++k) p.axes[axis][k] = r[k][axis] * (axis == 2 ? qfac : 1.0);
  return p;
}

// InputError naming the first qform parameter (quatern_b, _c, _d, qoffset_x, _y, _z) that is not a
// finite number: a NaN there made every axis NaN, which was reported as a sheared grid.
void check_qform_finite(const std::string& bytes, bool swap, const std::string& path) {
  static const char* const kNames[6] = {"quatern_b", "quatern_c", "quatern_d", "qoffset_x", "qoffset_y", "qoffset_z"};
  for (int k = 0; k < 6; ++k)
    if (const float value = nifti_field<float>(bytes, 256 + 4 * k, swap); !std::isfinite(value))
      throw InputError(path, kNames[k], std::string("the qform's ") + (k < 3 ? "quaternion" : "offset") +
                                            " parameter is not a finite number (" + exact(value) + ")");
}

// The header's "method 3": the sform's rows srow_x, srow_y, srow_z. Its column norms are the
// spacing, so that each voxel is where the affine puts it (nibabel's `affine` is the sform
// itself); a zero or non-finite column keeps pixdim's spacing and the default axis and is marked
// flat (harmless on an axis of one voxel, a 2D file's third).
NiftiPlacement sform_placement(const std::string& bytes, bool swap, const std::array<double, 3>& pixdim) {
  NiftiPlacement p;
  p.spacing = pixdim;
  for (int a = 0; a < 3; ++a) p.origin[a] = nifti_field<float>(bytes, 280 + 16 * a + 12, swap);
  for (int axis = 0; axis < 3; ++axis) {
    double column[3], norm = 0;
    for (int k = 0; k < 3; ++k) {
      column[k] = nifti_field<float>(bytes, 280 + 16 * k + 4 * axis, swap);
      norm += column[k] * column[k];
    }
    norm = std::sqrt(norm);
    p.flat[axis] = !(norm > 0 && std::isfinite(norm));
    if (p.flat[axis]) continue;
    p.spacing[axis] = norm;
    for (int k = 0; k < 3; ++k) p.axes[axis][k] = column[k] / norm;
  }
  return p;
}

// How far apart two placements put the grid of `size` voxels: the largest distance (mm) between
// their positions of the first voxel and of the grid's corner voxels, and the largest angle
// (degrees) between their directions of one index axis.
std::pair<double, double> placement_disagreement(const NiftiPlacement& s, const NiftiPlacement& q,
                                                 const std::array<int64_t, 3>& size) {
  double mm = 0, degrees = 0;
  for (int corner = 0; corner < 8; ++corner) {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      double ds = s.origin[k], dq = q.origin[k];
      for (int a = 0; a < 3; ++a) {
        const double index = (corner >> a & 1) ? double(size[a] - 1) : 0.0;
        ds += s.axes[a][k] * s.spacing[a] * index;
        dq += q.axes[a][k] * q.spacing[a] * index;
      }
      d2 += (ds - dq) * (ds - dq);
    }
    mm = std::max(mm, std::sqrt(d2));
  }
  for (int a = 0; a < 3; ++a) {
    if (size[a] <= 1) continue;  // an axis of one voxel (a 2D file's third) places nothing
    double dot = 0;
    for (int k = 0; k < 3; ++k) dot += s.axes[a][k] * q.axes[a][k];
    degrees = std::max(degrees, std::acos(std::clamp(dot, -1.0, 1.0)) * 180.0 / 3.14159265358979323846);
  }
  return {mm, degrees};
}

// Origin, spacing and axis directions by `choice` (image_io.h, NiftiTransform: nibabel's rule
// by default), in NIfTI's RAS (decode_nifti_header converts them to dsnake's LPS world). With
// `warn`, the one warning line of a disagreement or of a requested transform the file lacks.
void read_nifti_orientation(const std::string& bytes, bool swap, NiftiTransform choice, bool warn,
                            const std::string& path, RawVolume& v) {
  const bool has_q = nifti_field<int16_t>(bytes, 252, swap) > 0, has_s = nifti_field<int16_t>(bytes, 254, swap) > 0;
  const char* const wanted = choice == NiftiTransform::kSform ? "sform" : "qform";
  const bool lacks = (choice == NiftiTransform::kSform && !has_s) || (choice == NiftiTransform::kQform && !has_q);
  if (lacks) choice = NiftiTransform::kAuto;
  // A sform with no extent along an axis of several voxels (a zero or non-finite column) places
  // them all at one point: nibabel's affine is then singular. The qform (or pixdim) places them.
  const NiftiPlacement s = has_s ? sform_placement(bytes, swap, v.spacing) : NiftiPlacement{};
  int flat_axis = -1;
  for (int axis = 0; has_s && axis < v.ndims && flat_axis < 0; ++axis)
    if (v.size[axis] > 1 && s.flat[axis]) flat_axis = axis;
  const bool use_s = has_s && flat_axis < 0 && choice != NiftiTransform::kQform, use_q = !use_s && has_q;
  if (warn && flat_axis >= 0 && choice != NiftiTransform::kQform)
    std::fprintf(stderr, "dsnake: warning: %s: sform: its column for axis %d (%lld voxels) is zero or not finite, which "
                 "places them all at one point; using %s\n",
                 path.c_str(), flat_axis, static_cast<long long>(v.size[flat_axis]), use_q ? "the qform" : "pixdim at the origin");
  if (warn && lacks)
    std::fprintf(stderr, "dsnake: warning: %s: the %s was asked for (image.nifti_transform or --nifti-transform), but its "
                 "%s_code is 0; using %s\n",
                 path.c_str(), wanted, wanted, use_s ? "the sform" : use_q ? "the qform" : "pixdim at the origin");
  NiftiPlacement p;
  p.spacing = v.spacing;
  if (use_s) p = s;
  else if (use_q) {
    check_qform_finite(bytes, swap, path);
    p = qform_placement(bytes, swap, v.spacing);
  }
  if (warn && choice == NiftiTransform::kAuto && has_s && has_q) {
    const auto [mm, degrees] = placement_disagreement(p, qform_placement(bytes, swap, v.spacing), v.size);
    double voxel = std::numeric_limits<double>::infinity();
    for (int a = 0; a < v.ndims; ++a) voxel = std::min(voxel, p.spacing[a]);
    if (mm > voxel || degrees > 1.0)
      std::fprintf(stderr,
                   "dsnake: warning: %s: sform and qform disagree by %.3g mm / %.3g degrees; using the sform "
                   "(image.nifti_transform or --nifti-transform: qform for the qform)\n",
                   path.c_str(), mm, degrees);
  }
  v.origin = p.origin;
  v.axes = p.axes;
  v.spacing = p.spacing;
}

// Where a NIfTI-1 file's values are and how they become voxels (from the header).
struct NiftiData {
  Scalar type = Scalar::kF32;
  bool swap = false, scaled = false;
  double slope = 1, inter = 0;
  double offset = 0;       // vox_offset: the values' first byte
  int64_t count = 0;       // stored values: voxels x components
  int64_t voxels = 0;
  int channels = 1;
  size_t value_bytes = 4;
  size_t bytes = 0;        // count x value_bytes
};

// The data layout of header `bytes` (geometry already read into v), with the header's checks in
// their order: datatype, vox_offset (not negative), the number of values.
NiftiData nifti_data_layout(const std::string& bytes, const std::string& path, bool swap, const RawVolume& v) {
  const int16_t datatype = nifti_field<int16_t>(bytes, 70, swap);
  static const std::map<int, Scalar> types = {{2, Scalar::kU8},    {4, Scalar::kI16},   {8, Scalar::kI32},
                                              {16, Scalar::kF32},  {64, Scalar::kF64},  {256, Scalar::kI8},
                                              {512, Scalar::kU16}, {768, Scalar::kU32}};
  auto type_it = types.find(datatype);
  if (type_it == types.end()) throw InputError(path, "datatype", "unsupported datatype " + std::to_string(datatype));
  NiftiData d;
  d.type = type_it->second;
  d.swap = swap;
  const float vox_offset = nifti_field<float>(bytes, 108, swap);
  if (!(vox_offset >= 0))
    throw InputError(path, "vox_offset", "data offset " + exact(vox_offset) + " lies outside the file");
  // A single-file NIfTI-1's values follow its 348-byte header and the 4 bytes of the extension
  // flag: a smaller offset would read header bytes as voxels (nibabel refuses it too).
  if (vox_offset < float(kNiftiVoxOffset))
    throw InputError(path, "vox_offset", "data offset " + exact(vox_offset) + " lies inside the header (the values of a "
                                         ".nii start at byte 352 or later)");
  d.offset = vox_offset;
  d.voxels = v.num_voxels();
  d.channels = v.channels;
  d.count = d.voxels * v.channels;
  check_declared_values(double(d.count), path, "dim");
  d.value_bytes = size_t(scalar_bytes(d.type));
  d.bytes = size_t(d.count) * d.value_bytes;
  d.slope = nifti_field<float>(bytes, 112, swap), d.inter = nifti_field<float>(bytes, 116, swap);
  d.scaled = d.slope != 0 && std::isfinite(d.slope) && std::isfinite(d.inter);
  return d;
}

// Stored values are decoded this many at a time.
constexpr int64_t kNiftiBlock = int64_t(1) << 16;

// The m stored values at `data`, those of stored index start.. start + m - 1, into `values`:
// rescaled in double when scl_slope is set and rounded once (as an unscaled value is); NIfTI keeps
// components slowest (one volume per component), RawVolume interleaves them. A block at a time:
// a CT with scl_slope set, the usual case, decoded all at once in double would need 8 bytes a
// voxel more at the peak.
void decode_nifti_block(const NiftiData& d, const char* data, int64_t start, int64_t m, std::vector<float>& values) {
  if (!d.scaled && d.channels == 1) {  // the common case: the values themselves, in place
    decode_into(data, m, d.type, d.swap, values.data() + start);
    return;
  }
  const std::vector<double> stored = decode<double>(data, m, d.type, d.swap);
  int64_t c = start / d.voxels, i = start % d.voxels;  // the component and voxel of stored value c n + i
  for (int64_t k = 0; k < m; ++k) {
    const double s = stored[k];
    values[size_t(i * d.channels + c)] = float(d.scaled ? s * d.slope + d.inter : s);
    if (++i == d.voxels) i = 0, ++c;
  }
}

// Decodes a NIfTI-1 header (the geometry) from its bytes; read_nifti streams the values.
RawVolume decode_nifti_header(const std::string& bytes, const std::string& path, NiftiTransform transform,
                              bool warn) {
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
  read_nifti_orientation(bytes, swap, transform, warn, path, v);
  ras_to_lps(v);
  return v;
}

// The header (and the empty extension flag after it) of a float32 (or, for a label map, uint8)
// NIfTI-1 of `v`'s geometry. The LPS origin and directions are converted to NIfTI's RAS and
// stored twice, as ITK and nibabel write them: as the qform (quaternion, qform_code 1) and as the
// sform's rows (spacing times direction, sform_code 1).
std::string nifti_header_of(const RawVolume& v) {
  std::array<double, 3> origin = v.origin;  // in RAS
  std::array<std::array<double, 3>, 3> axes = v.axes;
  ras_to_lps(origin, axes);
  std::string h(kNiftiVoxOffset, '\0');
  put<int32_t>(h, 0, 348);
  std::array<int16_t, 8> dim{};
  dim.fill(1);
  dim[0] = int16_t(v.channels > 1 ? 5 : v.ndims);
  for (int a = 0; a < 3; ++a) dim[a + 1] = int16_t(a < v.ndims ? v.size[a] : 1);
  dim[5] = int16_t(v.channels);
  for (int i = 0; i < 8; ++i) put<int16_t>(h, 40 + 2 * i, dim[i]);
  if (v.channels > 1) put<int16_t>(h, 68, 1007);  // NIFTI_INTENT_VECTOR
  put<int16_t>(h, 70, v.label ? 2 : 16);  // uint8 or float32
  put<int16_t>(h, 72, v.label ? 8 : 32);
  const std::array<double, 4> q = quaternion_of(axes);
  put<float>(h, 76, float(q[3]));  // qfac
  for (int a = 0; a < 3; ++a) put<float>(h, 80 + 4 * a, float(a < v.ndims ? v.spacing[a] : 1.0));
  for (int i = 4; i < 8; ++i) put<float>(h, 76 + 4 * i, 1.0f);
  put<float>(h, 108, float(kNiftiVoxOffset));
  put<float>(h, 112, 1.0f);  // scl_slope
  put<int8_t>(h, 123, 2);    // xyzt_units: mm
  put<int16_t>(h, 252, 1);   // qform_code: scanner
  put<int16_t>(h, 254, 1);   // sform_code: scanner
  for (int k = 0; k < 3; ++k) put<float>(h, 256 + 4 * k, float(q[k]));
  for (int a = 0; a < 3; ++a) put<float>(h, 268 + 4 * a, float(origin[a]));
  for (int k = 0; k < 3; ++k) {  // srow_x, srow_y, srow_z
    for (int a = 0; a < 3; ++a)
      put<float>(h, 280 + 16 * k + 4 * a, float(axes[a][k] * (a < v.ndims ? v.spacing[a] : 1.0)));
    put<float>(h, 280 + 16 * k + 12, float(origin[k]));
  }
  std::memcpy(h.data() + 344, "n+1", 4);
  return h;
}

// Stores a header field in the header's own byte order (`swap`: the file's order is foreign).
template <class T>
void put_in_order(std::string& h, size_t offset, T value, bool swap) {
  put<T>(h, offset, value);
  if (swap) std::reverse(h.data() + offset, h.data() + offset + sizeof(T));
}

std::string nifti_header_for_values(const std::string& source, bool label, bool& swap) {
  DSNAKE_ASSERT(source.size() >= kNiftiHeaderBytes, "a whole NIfTI-1 header");
  swap = nifti_field<int32_t>(source, 0, false) != 348;
  std::string h = source.substr(0, kNiftiHeaderBytes);
  h.resize(kNiftiVoxOffset, '\0');  // extension flag 0: no extensions follow
  put_in_order<int16_t>(h, 70, label ? 2 : 16, swap);  // datatype: uint8 or float32
  put_in_order<int16_t>(h, 72, label ? 8 : 32, swap);  // bitpix
  put_in_order<float>(h, 108, float(kNiftiVoxOffset), swap);
  put_in_order<float>(h, 112, 1.0f, swap);  // scl_slope, scl_inter: the values as stored
  put_in_order<float>(h, 116, 0.0f, swap);
  if (label) {  // a mask is no statistic and has no display window of the source's intensities
    put_in_order<int16_t>(h, 68, 0, swap);  // intent_code: none
    put_in_order<float>(h, 124, 0.0f, swap);  // cal_max, cal_min: unset
    put_in_order<float>(h, 128, 0.0f, swap);
  }
  return h;
}

void write_nifti_parts(const std::vector<std::string_view>& parts, const std::string& path) {
  if (extension_of(path) == ".nii") write_file_atomically(path, parts);
  else write_stream_atomically(path, [&](const auto& put) { gzip_into(parts, path, put); });
}

// Writes a float32 (or, for a label map, uint8) NIfTI-1 (.nii, or gzipped .nii.gz) with
// nifti_header_of's header.
void write_nifti(const RawVolume& lps, const std::string& path) {
  const std::string h = nifti_header_of(lps);
  // NIfTI keeps components slowest (one volume per component); RawVolume interleaves them.
  std::vector<float> planar;
  if (lps.channels > 1) {
    const int64_t n = lps.num_voxels();
    const std::vector<float>& interleaved = lps.data();
    planar.resize(interleaved.size());
    for (int c = 0; c < lps.channels; ++c)
      for (int64_t i = 0; i < n; ++i) planar[c * n + i] = interleaved[i * lps.channels + c];
  }
  std::string converted;
  write_nifti_parts({h, stored_view(lps.channels > 1 ? planar : lps.data(), lps.label, converted)}, path);
}

RawVolume read_nifti(const std::string& path, NiftiTransform transform, std::string* header) {
  const std::string head = read_gz_bytes(path, kNiftiHeaderBytes);
  RawVolume v = decode_nifti_header(head, path, transform, /*warn=*/true);
  if (header) *header = head.substr(0, kNiftiHeaderBytes);
  const bool swap = nifti_field<int32_t>(head, 0, false) != 348;
  const double values = double(v.num_voxels()) * v.channels;
  check_declared_values(values, path, "dim");
  const double vox_offset = nifti_field<float>(head, 108, swap);
  const double declared = (std::isfinite(vox_offset) && vox_offset > 0 ? vox_offset : 0) + values * 8;  // at most 8 bytes a value
  std::error_code ec;
  const double stored = double(std::filesystem::file_size(path, ec));
  const bool gzipped = extension_of(path) == ".nii.gz";
  if (gzipped && !ec) check_inflatable(std::min(declared, values * 1 + 352), stored, path, "dim");
  const NiftiData layout = nifti_data_layout(head, path, swap, v);
  // An offset past all the file can hold is refused before it is used as a count of bytes.
  const double largest = ec ? 9.0e18 : gzipped ? kMaxInflateRatio * stored + 1024 : stored;
  if (layout.offset > largest)
    throw InputError(path, "vox_offset", "data offset " + exact(layout.offset) + " lies outside the file");
  // The values streamed from the file (through zlib's gz reader, which passes a plain .nii
  // through) a block at a time into the voxels: the file's bytes are never held whole, so that
  // reading needs the volume's floats and one block, not the stored values as well.
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw InputError(path, "", "cannot open file");
  struct Close {
    gzFile f;
    ~Close() { gzclose(f); }
  } close{f};
  gzbuffer(f, 1 << 17);
  // A plain (not gzipped) file must hold the values the header declares before room is made for
  // them: a small file can declare gigabytes (dim[5] components of 32767).
  if (gzdirect(f) && !ec && layout.offset + double(layout.bytes) > stored)
    throw InputError(path, "vox_offset", "data holds " + std::to_string(uint64_t(std::max(0.0, stored - std::floor(layout.offset)))) +
                                             " bytes, expected " +
                                             std::to_string(layout.bytes));
  std::string block(size_t(std::min<int64_t>(kNiftiBlock, std::max<int64_t>(layout.count, 1))) * layout.value_bytes, '\0');
  // Reads up to n bytes into block; returns how many (fewer only at the end of the file).
  auto read = [&](size_t n) {
    size_t got = 0;
    while (got < n) {
      const int r = gzread(f, block.data() + got, unsigned(n - got));
      if (r < 0) throw InputError(path, "", "corrupt gzip data");
      if (r == 0) break;
      got += size_t(r);
    }
    return got;
  };
  for (size_t skipped = 0, skip = size_t(layout.offset); skipped < skip;) {
    const size_t got = read(std::min(skip - skipped, block.size()));
    if (got == 0) throw InputError(path, "vox_offset", "data offset " + exact(layout.offset) + " lies outside the file");
    skipped += got;
  }
  v.values.resize(size_t(layout.count));
  size_t available = 0;
  for (int64_t start = 0; start < layout.count; start += kNiftiBlock) {
    const int64_t m = std::min(kNiftiBlock, layout.count - start);
    const size_t got = read(size_t(m) * layout.value_bytes);
    available += got;
    if (got < size_t(m) * layout.value_bytes)
      throw InputError(path, "vox_offset", "data holds " + std::to_string(available) + " bytes, expected " +
                                               std::to_string(layout.bytes));
    decode_nifti_block(layout, block.data(), start, m, v.values);
  }
  return v;
}

}  // namespace dsnake::detail
