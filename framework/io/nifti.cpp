// NIfTI reading (NIfTI-1 and NIfTI-2: single .nii/.nii.gz files and .hdr/.img pairs) and NIfTI-1
// writing (.nii/.nii.gz); see image_io.h.
#include "framework/io/image_io_detail.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
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
constexpr size_t kNifti2HeaderBytes = 540;

// ---------------------------------------------------------------- the header's fields

// One field of a NIfTI header in one version: the offset of its first element, the bytes of
// each element and what they hold (a signed integer; an unsigned byte when 1 byte; an IEEE
// float or double; or bytes as they are).
enum class NiftiKind : uint8_t { kInt, kReal, kBytes };
struct NiftiSlot {
  uint16_t offset;
  uint8_t size;
  NiftiKind kind;
};
struct NiftiFieldSpec {
  uint8_t count;  // elements
  NiftiSlot v1, v2;
};

enum NiftiField : int {
  kSizeofHdr, kMagic, kDimInfo, kDim, kIntentP, kIntentCode, kDatatype, kBitpix, kSliceStart, kPixdim, kVoxOffset,
  kSclSlope, kSclInter, kSliceEnd, kSliceCode, kXyztUnits, kCalMax, kCalMin, kSliceDuration, kToffset, kDescrip,
  kAuxFile, kQformCode, kSformCode, kQuatern, kQoffset, kSrow, kIntentName, kNiftiFieldCount
};

// The fields of the NIfTI-1 header (nifti1.h) and of the NIfTI-2 header (the NIfTI-2 spec,
// nifti2.h), which holds the same fields in another order and wider: int64 dim, slice_start,
// slice_end and vox_offset, double reals, int32 codes and units, an 8-byte magic after
// sizeof_hdr. Both versions are read through this one table (NiftiHeader), so that the checks
// and the placement rules below are written once; NIfTI-2's doubles are read as doubles.
// (NIfTI-1's ANALYZE leftovers, glmax/glmin and the unused strings, have no NIfTI-2 counterpart
// and are not read.)
constexpr NiftiFieldSpec kNiftiFields[kNiftiFieldCount] = {
    /* sizeof_hdr */ {1, {0, 4, NiftiKind::kInt}, {0, 4, NiftiKind::kInt}},
    /* magic */ {1, {344, 4, NiftiKind::kBytes}, {4, 8, NiftiKind::kBytes}},
    /* dim_info */ {1, {39, 1, NiftiKind::kBytes}, {524, 1, NiftiKind::kBytes}},
    /* dim[8] */ {8, {40, 2, NiftiKind::kInt}, {16, 8, NiftiKind::kInt}},
    /* intent_p1..3 */ {3, {56, 4, NiftiKind::kReal}, {80, 8, NiftiKind::kReal}},
    /* intent_code */ {1, {68, 2, NiftiKind::kInt}, {504, 4, NiftiKind::kInt}},
    /* datatype */ {1, {70, 2, NiftiKind::kInt}, {12, 2, NiftiKind::kInt}},
    /* bitpix */ {1, {72, 2, NiftiKind::kInt}, {14, 2, NiftiKind::kInt}},
    /* slice_start */ {1, {74, 2, NiftiKind::kInt}, {224, 8, NiftiKind::kInt}},
    /* pixdim[8] */ {8, {76, 4, NiftiKind::kReal}, {104, 8, NiftiKind::kReal}},
    /* vox_offset */ {1, {108, 4, NiftiKind::kReal}, {168, 8, NiftiKind::kInt}},
    /* scl_slope */ {1, {112, 4, NiftiKind::kReal}, {176, 8, NiftiKind::kReal}},
    /* scl_inter */ {1, {116, 4, NiftiKind::kReal}, {184, 8, NiftiKind::kReal}},
    /* slice_end */ {1, {120, 2, NiftiKind::kInt}, {232, 8, NiftiKind::kInt}},
    /* slice_code */ {1, {122, 1, NiftiKind::kInt}, {496, 4, NiftiKind::kInt}},
    /* xyzt_units */ {1, {123, 1, NiftiKind::kInt}, {500, 4, NiftiKind::kInt}},
    /* cal_max */ {1, {124, 4, NiftiKind::kReal}, {192, 8, NiftiKind::kReal}},
    /* cal_min */ {1, {128, 4, NiftiKind::kReal}, {200, 8, NiftiKind::kReal}},
    /* slice_duration */ {1, {132, 4, NiftiKind::kReal}, {208, 8, NiftiKind::kReal}},
    /* toffset */ {1, {136, 4, NiftiKind::kReal}, {216, 8, NiftiKind::kReal}},
    /* descrip */ {1, {148, 80, NiftiKind::kBytes}, {240, 80, NiftiKind::kBytes}},
    /* aux_file */ {1, {228, 24, NiftiKind::kBytes}, {320, 24, NiftiKind::kBytes}},
    /* qform_code */ {1, {252, 2, NiftiKind::kInt}, {344, 4, NiftiKind::kInt}},
    /* sform_code */ {1, {254, 2, NiftiKind::kInt}, {348, 4, NiftiKind::kInt}},
    /* quatern_b, _c, _d */ {3, {256, 4, NiftiKind::kReal}, {352, 8, NiftiKind::kReal}},
    /* qoffset_x, _y, _z */ {3, {268, 4, NiftiKind::kReal}, {376, 8, NiftiKind::kReal}},
    /* srow_x[4], srow_y[4], srow_z[4] */ {12, {280, 4, NiftiKind::kReal}, {400, 8, NiftiKind::kReal}},
    /* intent_name */ {1, {328, 16, NiftiKind::kBytes}, {508, 16, NiftiKind::kBytes}},
};

// A NIfTI-1 or NIfTI-2 header: its bytes as stored (at least its length), its version and
// byte order (both from sizeof_hdr: 348 or 540, native or swapped).
struct NiftiHeader {
  std::string_view bytes;
  int version = 1;
  bool swap = false;

  size_t size() const { return version == 1 ? kNiftiHeaderBytes : kNifti2HeaderBytes; }
  // The smallest vox_offset of a single file: the header and the 4 bytes of the extension flag.
  size_t first_value_byte() const { return size() + 4; }
  const NiftiSlot& slot(NiftiField f) const { return version == 1 ? kNiftiFields[f].v1 : kNiftiFields[f].v2; }
  const char* at(NiftiField f, int i) const { return bytes.data() + slot(f).offset + size_t(i) * slot(f).size; }
  // Element i of an integer field, in the file's byte order.
  int64_t integer(NiftiField f, int i = 0) const {
    const char* p = at(f, i);
    switch (slot(f).size) {
      case 1: return uint8_t(*p);
      case 2: return load_as<int16_t>(p, swap);
      case 4: return load_as<int32_t>(p, swap);
      default: return load_as<int64_t>(p, swap);
    }
  }
  // Element i of a real field (or of an integer one: NIfTI-2's vox_offset), as a double.
  double real(NiftiField f, int i = 0) const {
    if (slot(f).kind == NiftiKind::kInt) return double(integer(f, i));
    return slot(f).size == 4 ? load<float>(at(f, i), swap) : load<double>(at(f, i), swap);
  }
  std::string_view text(NiftiField f) const { return bytes.substr(slot(f).offset, slot(f).size); }
};

// The version and byte order of the header in `bytes` (0: sizeof_hdr is neither 348 nor 540 in
// either byte order, or there are fewer than 4 bytes); its length is not checked.
NiftiHeader identify_nifti(std::string_view bytes) {
  NiftiHeader h;
  h.bytes = bytes;
  h.version = 0;
  if (bytes.size() < 4) return h;
  for (const bool swap : {false, true}) {
    const int32_t sizeof_hdr = load_as<int32_t>(bytes.data(), swap);
    if (sizeof_hdr == 348 || sizeof_hdr == 540) {
      h.version = sizeof_hdr == 348 ? 1 : 2;
      h.swap = swap;
      break;
    }
  }
  return h;
}

// The header of `path` read from its first bytes, its length and magic checked: "n+1" or "n+2"
// for a single file, "ni1" or "ni2" for the header of a .hdr/.img pair (`pair`); a NIfTI-2
// magic goes on with the bytes \r\n\032\n (or zeros, which nibabel takes too), which a transfer
// that converts line ends would have altered (the NIfTI-2 spec).
NiftiHeader parse_nifti_header(const std::string& bytes, const std::string& path, bool pair) {
  const NiftiHeader h = identify_nifti(bytes);
  auto too_short = [&](int version) {
    return InputError(path, "header", "unreadable header: file holds " + std::to_string(bytes.size()) +
                                          " bytes, a NIfTI-" + std::to_string(version) + " header needs " +
                                          (version == 1 ? "348" : "540"));
  };
  if (h.version == 0 && bytes.size() < kNiftiHeaderBytes) throw too_short(1);
  if (h.version == 0)
    throw InputError(path, "sizeof_hdr", "not a NIfTI file (sizeof_hdr = " +
                                             std::to_string(load_as<int32_t>(bytes.data(), false)) +
                                             "; NIfTI-1 has 348, NIfTI-2 540)");
  if (bytes.size() < h.size()) throw too_short(h.version);
  const std::string_view magic = h.text(kMagic).substr(0, 4);
  const std::string v = std::to_string(h.version);
  const std::string single = "n+" + v + std::string(1, '\0'), paired = "ni" + v + std::string(1, '\0');
  if (!pair && magic != single) {
    throw InputError(path, "magic", "not a single-file NIfTI-" + v + " (magic \"n+" + v + "\")" +
                                        (magic == paired ? ": \"ni" + v + "\" marks the header of a .hdr/.img pair; "
                                                           "name it .hdr"
                                                         : std::string()));
  }
  if (pair && magic != paired) {
    if (magic == single)
      throw InputError(path, "magic", "\"n+" + v + "\" marks a single-file NIfTI-" + v +
                                          ", whose values follow its header: name it .nii");
    if (h.version == 1)
      throw InputError(path, "magic", "no NIfTI magic (\"ni1\"): an ANALYZE 7.5 header, which has no orientation "
                                      "(which way its axes run is ambiguous); convert it to NIfTI with the tool "
                                      "that made it");
    throw InputError(path, "magic", "not the header of a NIfTI-2 pair (magic \"ni2\")");
  }
  if (h.version == 2) {
    const std::string_view eol = h.text(kMagic).substr(4);
    if (eol != std::string_view("\r\n\032\n", 4) && eol != std::string_view("\0\0\0\0", 4))
      throw InputError(path, "magic", "the NIfTI-2 magic's last 4 bytes are not \\r\\n\\032\\n: the file was altered, "
                                      "as by a transfer that converts line ends");
  }
  return h;
}

// Whether `path` names one file of a .hdr/.img pair.
bool is_nifti_pair_path(const std::string& path) {
  const std::string ext = extension_of(path);
  return ext == ".hdr" || ext == ".hdr.gz" || ext == ".img" || ext == ".img.gz";
}

// Stores a header field in native (little-endian) order.
template <class T>
void put(std::string& h, size_t offset, T value) {
  std::memcpy(h.data() + offset, &value, sizeof(T));
}

// Stores a header field in the header's own byte order (`swap`: the file's order is foreign).
template <class T>
void put_in_order(std::string& h, size_t offset, T value, bool swap) {
  put<T>(h, offset, value);
  if (swap) std::reverse(h.data() + offset, h.data() + offset + sizeof(T));
}

// Stores fields of kNiftiFields into header bytes `h` in `layout`'s version and byte order:
// integers in their field's width, reals as float (NIfTI-1) or double (NIfTI-2), and a real given
// for an integer field (NIfTI-2's vox_offset) as that integer.
struct NiftiFieldWriter {
  std::string& h;
  NiftiHeader layout;

  void integer(NiftiField f, int64_t x, int i = 0) const {
    const NiftiSlot& slot = layout.slot(f);
    const size_t at = slot.offset + size_t(i) * slot.size;
    if (slot.size == 1) h[at] = char(uint8_t(x));
    else if (slot.size == 2) put_in_order<int16_t>(h, at, int16_t(x), layout.swap);
    else if (slot.size == 4) put_in_order<int32_t>(h, at, int32_t(x), layout.swap);
    else put_in_order<int64_t>(h, at, x, layout.swap);
  }
  void real(NiftiField f, double x, int i = 0) const {
    const NiftiSlot& slot = layout.slot(f);
    const size_t at = slot.offset + size_t(i) * slot.size;
    if (slot.kind == NiftiKind::kInt) integer(f, int64_t(x), i);
    else if (slot.size == 4) put_in_order<float>(h, at, float(x), layout.swap);
    else put_in_order<double>(h, at, x, layout.swap);
  }
  // A single file's magic: "n+1", or "n+2" and the bytes the NIfTI-2 spec puts after it.
  void single_file_magic() const {
    if (layout.version == 1) std::memcpy(h.data() + layout.slot(kMagic).offset, "n+1", 4);
    else std::memcpy(h.data() + layout.slot(kMagic).offset, "n+2\0\r\n\032\n", 8);
  }
};

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

// One of the ways a NIfTI header places its voxels, in NIfTI's RAS: voxel (i, j, k) is at
// origin + sum_a spacing[a] index[a] axes[a].
struct NiftiPlacement {
  std::array<double, 3> origin{0, 0, 0};
  std::array<std::array<double, 3>, 3> axes{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  std::array<double, 3> spacing{1, 1, 1};
  std::array<bool, 3> flat{false, false, false};  // sform: the axis's column is zero or not finite
};

// The header's "method 2": the qform (quaternion b, c, d, qfac in pixdim[0], qoffset), with
// pixdim's spacing.
NiftiPlacement qform_placement(const NiftiHeader& h, const std::array<double, 3>& pixdim) {
  NiftiPlacement p;
  p.spacing = pixdim;
  for (int a = 0; a < 3; ++a) p.origin[a] = h.real(kQoffset, a);
  double b = h.real(kQuatern, 0), c = h.real(kQuatern, 1), d = h.real(kQuatern, 2);
  // As NIfTI's reference code does (for NIfTI-2's doubles too): when a^2 = 1 - (b^2 + c^2 + d^2)
  // is below 1e-7 (a half turn, whose float32 (b, c, d) leave a tiny positive rest), a is 0 and
  // (b, c, d) is renormalised; else the rest would tilt the axes by ~0.015 degrees and make a
  // plain axis permutation look oblique.
  double a = 1.0 - (b * b + c * c + d * d);
  if (a < 1e-7) {
    const double norm = std::sqrt(b * b + c * c + d * d);
    if (norm > 0) b /= norm, c /= norm, d /= norm;
    a = 0;
  } else {
    a = std::sqrt(a);
  }
  const double qfac = h.real(kPixdim, 0) < 0 ? -1.0 : 1.0;
  const double r[3][3] = {{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
                          {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
                          {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - b * b - c * c}};
  for (int axis = 0; axis < 3; ++axis)
    for (int k = 0; k < 3; ++k) p.axes[axis][k] = r[k][axis] * (axis == 2 ? qfac : 1.0);
  return p;
}

// InputError naming the first qform parameter (quatern_b, _c, _d, qoffset_x, _y, _z) that is not a
// finite number: a NaN there made every axis NaN, which was reported as a sheared grid.
void check_qform_finite(const NiftiHeader& h, const std::string& path) {
  static const char* const kNames[6] = {"quatern_b", "quatern_c", "quatern_d", "qoffset_x", "qoffset_y", "qoffset_z"};
  for (int k = 0; k < 6; ++k)
    if (const double value = k < 3 ? h.real(kQuatern, k) : h.real(kQoffset, k - 3); !std::isfinite(value))
      throw InputError(path, kNames[k], std::string("the qform's ") + (k < 3 ? "quaternion" : "offset") +
                                            " parameter is not a finite number (" + exact(value) + ")");
}

// The header's "method 3": the sform's rows srow_x, srow_y, srow_z. Its column norms are the
// spacing, so that each voxel is where the affine puts it (nibabel's `affine` is the sform
// itself); a zero or non-finite column keeps pixdim's spacing and the default axis and is marked
// flat (harmless on an axis of one voxel, a 2D file's third).
NiftiPlacement sform_placement(const NiftiHeader& h, const std::array<double, 3>& pixdim) {
  NiftiPlacement p;
  p.spacing = pixdim;
  for (int a = 0; a < 3; ++a) p.origin[a] = h.real(kSrow, 4 * a + 3);
  for (int axis = 0; axis < 3; ++axis) {
    double column[3], norm = 0;
    for (int k = 0; k < 3; ++k) {
      column[k] = h.real(kSrow, 4 * k + axis);
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
void read_nifti_orientation(const NiftiHeader& h, NiftiTransform choice, bool warn, const std::string& path,
                            RawVolume& v) {
  const bool has_q = h.integer(kQformCode) > 0, has_s = h.integer(kSformCode) > 0;
  const char* const wanted = choice == NiftiTransform::kSform ? "sform" : "qform";
  const bool lacks = (choice == NiftiTransform::kSform && !has_s) || (choice == NiftiTransform::kQform && !has_q);
  if (lacks) choice = NiftiTransform::kAuto;
  // A sform with no extent along an axis of several voxels (a zero or non-finite column) places
  // them all at one point: nibabel's affine is then singular. The qform (or pixdim) places them.
  const NiftiPlacement s = has_s ? sform_placement(h, v.spacing) : NiftiPlacement{};
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
    check_qform_finite(h, path);
    p = qform_placement(h, v.spacing);
  }
  if (warn && choice == NiftiTransform::kAuto && has_s && has_q) {
    const auto [mm, degrees] = placement_disagreement(p, qform_placement(h, v.spacing), v.size);
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

// Where a NIfTI file's values are and how they become voxels (from the header).
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

// The data layout of header `h` (geometry already read into v), with the header's checks in
// their order: datatype, vox_offset (not negative; in a single file, past the header), the
// number of values. `pair`: the values are in the .img of a .hdr/.img pair, where they may
// start at byte 0.
NiftiData nifti_data_layout(const NiftiHeader& h, const std::string& path, bool pair, const RawVolume& v) {
  const int64_t datatype = h.integer(kDatatype);
  static const std::map<int64_t, Scalar> types = {
      {2, Scalar::kU8},     {4, Scalar::kI16},   {8, Scalar::kI32},  {16, Scalar::kF32},   {64, Scalar::kF64},
      {256, Scalar::kI8},   {512, Scalar::kU16}, {768, Scalar::kU32}, {1024, Scalar::kI64}, {1280, Scalar::kU64}};
  auto type_it = types.find(datatype);
  if (type_it == types.end()) throw InputError(path, "datatype", "unsupported datatype " + std::to_string(datatype));
  NiftiData d;
  d.type = type_it->second;
  d.swap = h.swap;
  const double vox_offset = h.real(kVoxOffset);
  if (!(vox_offset >= 0))
    throw InputError(path, "vox_offset", "data offset " + exact(vox_offset) + " lies outside the file");
  // A single file's values follow its header (348 bytes, NIfTI-2: 540) and the 4 bytes of the
  // extension flag: a smaller offset would read header bytes as voxels (nibabel refuses it too).
  if (!pair && vox_offset < double(h.first_value_byte()))
    throw InputError(path, "vox_offset", "data offset " + exact(vox_offset) + " lies inside the header (the values " +
                                             "of a " + (h.version == 1 ? "" : "NIfTI-2 ") + ".nii start at byte " +
                                             std::to_string(h.first_value_byte()) + " or later)");
  d.offset = vox_offset;
  d.voxels = v.num_voxels();
  d.channels = v.channels;
  d.count = d.voxels * v.channels;
  check_declared_values(double(d.count), path, "dim");
  d.value_bytes = size_t(scalar_bytes(d.type));
  d.bytes = size_t(d.count) * d.value_bytes;
  d.slope = h.real(kSclSlope), d.inter = h.real(kSclInter);
  d.scaled = d.slope != 0 && std::isfinite(d.slope) && std::isfinite(d.inter);
  return d;
}

// Stored values are decoded this many at a time.
constexpr int64_t kNiftiBlock = int64_t(1) << 16;

// The m stored values at `data`, those of stored index start.. start + m - 1, into `values`:
// rescaled in double when scl_slope is set and rounded once (as an unscaled value is, straight
// to float: a 64-bit integer through double would be rounded twice); NIfTI keeps components
// slowest (one volume per component), RawVolume interleaves them. A block at a time: a CT with
// scl_slope set, the usual case, decoded all at once in double would need 8 bytes a voxel more
// at the peak.
void decode_nifti_block(const NiftiData& d, const char* data, int64_t start, int64_t m, std::vector<float>& values) {
  if (!d.scaled && d.channels == 1) {  // the common case: the values themselves, in place
    decode_into(data, m, d.type, d.swap, values.data() + start);
    return;
  }
  std::vector<double> scaled;
  std::vector<float> plain;
  if (d.scaled) scaled = decode<double>(data, m, d.type, d.swap);
  else plain = decode<float>(data, m, d.type, d.swap);
  int64_t c = start / d.voxels, i = start % d.voxels;  // the component and voxel of stored value c n + i
  for (int64_t k = 0; k < m; ++k) {
    values[size_t(i * d.channels + c)] = d.scaled ? float(scaled[k] * d.slope + d.inter) : plain[k];
    if (++i == d.voxels) i = 0, ++c;
  }
}

// The geometry of header `h` (checked: dim, pixdim as the spacing, the placement by `transform`),
// in dsnake's LPS world. NIfTI-2's 64-bit dims are held to what an axis of a Grid can count.
RawVolume decode_nifti_geometry(const NiftiHeader& h, const std::string& path, NiftiTransform transform, bool warn) {
  RawVolume v;
  v.dim_key = "dim";
  v.spacing_key = "pixdim";
  v.channel_key = "dim[5]";
  std::array<int64_t, 8> dim;
  for (int i = 0; i < 8; ++i) dim[i] = h.integer(kDim, i);
  if (dim[0] < 2 || dim[0] > 5)
    throw InputError(path, "dim", "unsupported dimension " + std::to_string(dim[0]) + " (expected 2 or 3)");
  for (int i = 1; i <= dim[0]; ++i) {
    const std::string name = "dim[" + std::to_string(i) + "] = " + std::to_string(dim[i]);
    if (dim[i] < 1) throw InputError(path, "dim", name + " is not positive");
    if (dim[i] > std::numeric_limits<int32_t>::max())
      throw InputError(path, "dim", name + " is more than the 2147483647 voxels an axis can hold");
  }
  if (dim[0] >= 4 && dim[4] != 1) throw InputError(path, "dim", "time series (dim[4] > 1) are not supported");
  v.ndims = dim[0] == 2 ? 2 : 3;
  for (int a = 0; a < v.ndims; ++a) v.size[a] = dim[a + 1];
  v.channels = dim[0] == 5 ? int(dim[5]) : 1;
  for (int a = 0; a < 3; ++a) v.spacing[a] = h.real(kPixdim, a + 1);
  read_nifti_orientation(h, transform, warn, path, v);
  ras_to_lps(v);
  return v;
}

// Decodes a NIfTI-1 or NIfTI-2 header (the geometry) from its bytes; read_nifti streams the values.
RawVolume decode_nifti_header(const std::string& bytes, const std::string& path, NiftiTransform transform,
                              bool warn) {
  return decode_nifti_geometry(parse_nifti_header(bytes, path, is_nifti_pair_path(path)), path, transform, warn);
}

// The header (and the empty extension flag after it) of a float32 (or, for a label map, uint8)
// NIfTI of `v`'s geometry: NIfTI-1, or NIfTI-2 for a grid of more than 32767 voxels along an axis
// (NIfTI-1's dim is int16), in native byte order. The LPS origin and directions are converted to
// NIfTI's RAS and stored twice, as ITK and nibabel write them: as the qform (quaternion,
// qform_code 1) and as the sform's rows (spacing times direction, sform_code 1).
std::string nifti_header_of(const RawVolume& v) {
  NiftiHeader layout;
  layout.version = 1;
  for (int a = 0; a < v.ndims; ++a)
    if (v.size[a] > std::numeric_limits<int16_t>::max()) layout.version = 2;
  std::array<double, 3> origin = v.origin;  // in RAS
  std::array<std::array<double, 3>, 3> axes = v.axes;
  ras_to_lps(origin, axes);
  std::string h(layout.first_value_byte(), '\0');
  const NiftiFieldWriter w{h, layout};
  w.integer(kSizeofHdr, int64_t(layout.size()));
  w.single_file_magic();
  std::array<int64_t, 8> dim{};
  dim.fill(1);
  dim[0] = v.channels > 1 ? 5 : v.ndims;
  for (int a = 0; a < 3; ++a) dim[a + 1] = a < v.ndims ? v.size[a] : 1;
  dim[5] = v.channels;
  for (int i = 0; i < 8; ++i) w.integer(kDim, dim[i], i);
  if (v.channels > 1) w.integer(kIntentCode, 1007);  // NIFTI_INTENT_VECTOR
  w.integer(kDatatype, v.label ? 2 : 16);  // uint8 or float32
  w.integer(kBitpix, v.label ? 8 : 32);
  const std::array<double, 4> q = quaternion_of(axes);
  w.real(kPixdim, q[3], 0);  // qfac
  for (int a = 0; a < 3; ++a) w.real(kPixdim, a < v.ndims ? v.spacing[a] : 1.0, a + 1);
  for (int i = 4; i < 8; ++i) w.real(kPixdim, 1.0, i);
  w.real(kVoxOffset, double(layout.first_value_byte()));
  w.real(kSclSlope, 1.0);
  w.integer(kXyztUnits, 2);  // mm
  w.integer(kQformCode, 1);  // scanner
  w.integer(kSformCode, 1);
  for (int k = 0; k < 3; ++k) w.real(kQuatern, q[k], k);
  for (int a = 0; a < 3; ++a) w.real(kQoffset, origin[a], a);
  for (int k = 0; k < 3; ++k) {  // srow_x, srow_y, srow_z
    for (int a = 0; a < 3; ++a) w.real(kSrow, axes[a][k] * (a < v.ndims ? v.spacing[a] : 1.0), 4 * k + a);
    w.real(kSrow, origin[k], 4 * k + 3);
  }
  return h;
}

// Whether every axis of the image `h` describes fits NIfTI-1's int16 dim.
bool fits_nifti1(const NiftiHeader& h) {
  const int64_t n = std::clamp<int64_t>(h.integer(kDim, 0), 0, 7);
  for (int i = 1; i <= n; ++i)
    if (h.integer(kDim, i) > std::numeric_limits<int16_t>::max()) return false;
  return true;
}

// A NIfTI-2 header's fields (kNiftiFields) as a NIfTI-1 header (348 bytes, native byte order),
// for writing a NIfTI-1 on its grid: reals rounded to float, integers where NIfTI-1's narrower
// fields hold them. The image's grid must fit (fits_nifti1); any other integer beyond its NIfTI-1
// field (an unused dim, a code, a slice index) is stored as unset (1 for a dim, else 0).
std::string nifti1_header_of(const NiftiHeader& in) {
  DSNAKE_ASSERT(fits_nifti1(in), "a grid NIfTI-1 can hold");
  std::string h(kNiftiHeaderBytes, '\0');
  const NiftiFieldWriter w{h, NiftiHeader{}};
  w.integer(kSizeofHdr, int64_t(kNiftiHeaderBytes));
  for (int f = 0; f < kNiftiFieldCount; ++f) {
    const NiftiField field = NiftiField(f);
    const NiftiSlot& to = w.layout.slot(field);
    if (field == kSizeofHdr || field == kMagic) continue;
    if (to.kind == NiftiKind::kBytes) {
      std::memcpy(h.data() + to.offset, in.at(field, 0), std::min(to.size, in.slot(field).size));
      continue;
    }
    for (int i = 0; i < kNiftiFields[f].count; ++i) {
      if (to.kind == NiftiKind::kReal) {
        w.real(field, in.real(field, i), i);  // (beyond float's range: infinite)
        continue;
      }
      int64_t x = in.integer(field, i);
      const int64_t hi = to.size == 1   ? 255
                         : to.size == 2 ? std::numeric_limits<int16_t>::max()
                                        : std::numeric_limits<int32_t>::max();
      const int64_t lo = to.size == 1 ? 0 : -hi - 1;
      if (x < lo || x > hi) x = field == kDim ? 1 : 0;
      w.integer(field, x, i);
    }
  }
  return h;
}

std::string nifti_header_for_values(const std::string& source, bool label, bool& swap) {
  const NiftiHeader in = identify_nifti(source);
  DSNAKE_ASSERT(in.version != 0 && source.size() >= in.size(), "a whole NIfTI-1 or NIfTI-2 header");
  // A NIfTI-2 source is written as NIfTI-1, which every reader opens, unless its grid does not
  // fit; then as NIfTI-2, its own header in its own byte order.
  NiftiHeader out;
  out.version = in.version == 2 && !fits_nifti1(in) ? 2 : 1;
  std::string h;
  if (in.version == out.version) {
    swap = in.swap;
    h = source.substr(0, in.size());
  } else {
    swap = false;
    h = nifti1_header_of(in);
  }
  h.resize(out.first_value_byte(), '\0');  // extension flag 0: no extensions follow
  out.swap = swap;
  const NiftiFieldWriter w{h, out};
  w.single_file_magic();  // (a pair's header says "ni1" / "ni2")
  w.integer(kDatatype, label ? 2 : 16);  // uint8 or float32
  w.integer(kBitpix, label ? 8 : 32);
  w.real(kVoxOffset, double(out.first_value_byte()));
  w.real(kSclSlope, 1.0);  // scl_slope, scl_inter: the values as stored
  w.real(kSclInter, 0.0);
  if (label) {  // a mask is no statistic and has no display window of the source's intensities
    w.integer(kIntentCode, 0);
    w.real(kCalMax, 0.0);
    w.real(kCalMin, 0.0);
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

namespace {

// The files of a NIfTI input: the header's and the values'. A single .nii/.nii.gz is both; a
// .hdr/.img pair is named by either of its files (X.hdr or X.img, each optionally gzipped), the
// other being found beside it as NIfTI's reference library finds it: the same name with the other
// extension (in the same case), gzipped as the named file is, else the other way.
struct NiftiFiles {
  std::string header, data;
  bool pair = false;
};

// The other file of the pair `path` names: its .img for a .hdr (`to` "img"), its .hdr for a .img.
std::string pair_partner(const std::string& path, const std::string& to) {
  const fs::path p(path);
  std::string name = p.filename().string();
  std::string gz;
  if (name.size() > 3 && std::tolower(static_cast<unsigned char>(name[name.size() - 1])) == 'z' &&
      std::tolower(static_cast<unsigned char>(name[name.size() - 2])) == 'g' && name[name.size() - 3] == '.') {
    gz = name.substr(name.size() - 3);
    name.resize(name.size() - 3);
  }
  const bool upper = std::isupper(static_cast<unsigned char>(name.back())) != 0;
  std::string ext = "." + to;
  if (upper) std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::toupper(c)); });
  const std::string stem = (p.parent_path() / name.substr(0, name.size() - 4)).string();
  const std::string same = stem + ext + gz, other = stem + ext + (gz.empty() ? (upper ? ".GZ" : ".gz") : "");
  std::error_code ec;
  return fs::exists(same, ec) || !fs::exists(other, ec) ? same : other;
}

NiftiFiles nifti_files(const std::string& path) {
  if (!is_nifti_pair_path(path)) return {path, path, false};
  require_exists(path);
  const std::string ext = extension_of(path);
  NiftiFiles files;
  files.pair = true;
  if (ext == ".hdr" || ext == ".hdr.gz") {
    files.header = path;
    files.data = pair_partner(path, "img");
  } else {
    files.data = path;
    files.header = pair_partner(path, "hdr");
    std::error_code ec;
    if (!fs::exists(files.header, ec))
      throw InputError(files.header, "", "file not found (the header of the NIfTI pair whose image file is " + path +
                                             ")");
  }
  return files;
}

// The values' file, read from its first byte: through zlib's gz reader, which gunzips a .gz file
// and passes a plain .nii through, or, a plain .img, as it is: an .img holds only values, and
// values that happen to begin with the gzip magic bytes must not be inflated.
class NiftiValuesFile {
 public:
  NiftiValuesFile(const std::string& path, bool raw) : path_(path) {
    if (raw) {
      in_.open(path, std::ios::binary);
      if (!in_) throw InputError(path, "", "cannot open file");
      return;
    }
    gz_ = gzopen(path.c_str(), "rb");
    if (!gz_) throw InputError(path, "", "cannot open file");
    gzbuffer(gz_, 1 << 17);
  }
  ~NiftiValuesFile() {
    if (gz_) gzclose(gz_);
  }
  NiftiValuesFile(const NiftiValuesFile&) = delete;
  NiftiValuesFile& operator=(const NiftiValuesFile&) = delete;
  // Whether the bytes are the file's own (not inflated).
  bool plain() { return !gz_ || gzdirect(gz_); }
  // Reads up to n bytes into out; returns how many (fewer only at the end of the file).
  size_t read(char* out, size_t n) {
    if (!gz_) {
      in_.read(out, std::streamsize(n));
      return size_t(in_.gcount());
    }
    size_t got = 0;
    while (got < n) {
      const int r = gzread(gz_, out + got, unsigned(std::min<size_t>(n - got, size_t(1) << 30)));
      if (r < 0) throw InputError(path_, "", "corrupt gzip data");
      if (r == 0) break;
      got += size_t(r);
    }
    return got;
  }

 private:
  std::string path_;
  gzFile gz_ = nullptr;
  std::ifstream in_;
};

}  // namespace

int nifti_dimension(const std::string& path) {
  const NiftiFiles files = nifti_files(path);
  return decode_nifti_header(read_gz_bytes(files.header, kNifti2HeaderBytes), files.header).effective_dimension();
}

RawVolume read_nifti(const std::string& path, NiftiTransform transform, std::string* header) {
  const NiftiFiles files = nifti_files(path);
  const std::string head = read_gz_bytes(files.header, kNifti2HeaderBytes);
  const NiftiHeader h = parse_nifti_header(head, files.header, files.pair);
  RawVolume v = decode_nifti_geometry(h, files.header, transform, /*warn=*/true);
  if (header) *header = head.substr(0, h.size());
  // The count in double: NIfTI-2's dims (each up to 2^31 - 1) can overflow 64 bits. Past the
  // memory limit, which the environment may raise without bound, the values' bytes (up to 8 a
  // value) must still be countable in int64 (NIfTI-1's largest, 32767^4 values, are).
  const double values = double(v.size[0]) * double(v.size[1]) * double(v.size[2]) * v.channels;
  check_declared_values(values, files.header, "dim");
  if (!(values * 8 < 0x1p63))
    throw InputError(files.header, "dim",
                     "declares " + exact(values) + " values, more than a 64-bit count of bytes holds");
  // A pair's values are in its .img, which must be there (and a regular file).
  std::error_code ec;
  if (files.pair && !fs::exists(files.data, ec))
    throw InputError(files.data, "", "file not found (the image file of the NIfTI pair whose header is " +
                                         files.header + ")");
  if (files.pair) require_exists(files.data);
  const double vox_offset = h.real(kVoxOffset);
  const double declared = (std::isfinite(vox_offset) && vox_offset > 0 ? vox_offset : 0) + values * 8;  // at most 8 bytes a value
  const double stored = double(std::filesystem::file_size(files.data, ec));
  const std::string data_ext = extension_of(files.data);
  const bool gzipped = data_ext == ".nii.gz" || data_ext == ".img.gz";
  const double least_offset = files.pair ? 0.0 : double(h.first_value_byte());
  if (gzipped && !ec) check_inflatable(std::min(declared, values * 1 + least_offset), stored, files.data, "dim");
  const NiftiData layout = nifti_data_layout(h, files.header, files.pair, v);
  // An offset past all the file can hold is refused before it is used as a count of bytes.
  const double largest = ec ? 9.0e18 : gzipped ? kMaxInflateRatio * stored + 1024 : stored;
  if (layout.offset > largest)
    throw InputError(files.data, "vox_offset", "data offset " + exact(layout.offset) + " lies outside the file");
  // The values streamed from the file (through zlib's gz reader, which passes a plain .nii
  // through) a block at a time into the voxels: the file's bytes are never held whole, so that
  // reading needs the volume's floats and one block, not the stored values as well.
  NiftiValuesFile f(files.data, data_ext == ".img");
  // A plain (not gzipped) file must hold the values the header declares before room is made for
  // them: a small file can declare gigabytes (dim[5] components of 32767).
  if (f.plain() && !ec && layout.offset + double(layout.bytes) > stored)
    throw InputError(files.data, "vox_offset",
                     "data holds " + std::to_string(uint64_t(std::max(0.0, stored - std::floor(layout.offset)))) +
                         " bytes, expected " + std::to_string(layout.bytes));
  std::string block(size_t(std::min<int64_t>(kNiftiBlock, std::max<int64_t>(layout.count, 1))) * layout.value_bytes, '\0');
  for (size_t skipped = 0, skip = size_t(layout.offset); skipped < skip;) {
    const size_t got = f.read(block.data(), std::min(skip - skipped, block.size()));
    if (got == 0)
      throw InputError(files.data, "vox_offset", "data offset " + exact(layout.offset) + " lies outside the file");
    skipped += got;
  }
  v.values.resize(size_t(layout.count));
  size_t available = 0;
  for (int64_t start = 0; start < layout.count; start += kNiftiBlock) {
    const int64_t m = std::min(kNiftiBlock, layout.count - start);
    const size_t got = f.read(block.data(), size_t(m) * layout.value_bytes);
    available += got;
    if (got < size_t(m) * layout.value_bytes)
      throw InputError(files.data, "vox_offset", "data holds " + std::to_string(available) + " bytes, expected " +
                                                     std::to_string(layout.bytes));
    decode_nifti_block(layout, block.data(), start, m, v.values);
  }
  return v;
}

}  // namespace dsnake::detail
