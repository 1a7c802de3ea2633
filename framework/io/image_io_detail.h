// Internal to the image I/O (framework/io/image_io.cpp, metaimage.cpp, nifti.cpp, nrrd.cpp, source_grid.cpp,
// inr.cpp): the decoded form every reader produces and the byte helpers the formats share. Not part of the API.
#pragma once

#include "framework/io/image_io.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <cstdio>
#include <exception>
#include <fcntl.h>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>
#include <unistd.h>

namespace dsnake::detail {

// A decoded image of any supported format, before the checks for one dimension D.
struct RawVolume {
  int ndims = 3;                              // spatial dimensions as stored (2 or 3)
  std::array<int64_t, 3> size{1, 1, 1};       // voxels per axis (unused axes: 1)
  std::array<double, 3> spacing{1, 1, 1};     // physical voxel size per axis
  std::array<double, 3> origin{0, 0, 0};      // physical position of voxel 0
  // axes[a]: the unit world direction of index axis a as the file stores it (MetaImage
  // TransformMatrix, NIfTI qform/sform); image_io.cpp's align_axes() reorders the voxels so that it is +e_a.
  std::array<std::array<double, 3>, 3> axes{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  int channels = 1;                           // 1 for an image, D for a vector field
  bool label = false;                         // writers: store as uint8 (a label map), else float32
  std::vector<float> values;                  // voxel-major (x fastest), channels interleaved (float,
                                              // the precision of Image; 4 bytes a value while a file is read)
  std::string dim_key = "dimension", spacing_key = "spacing", channel_key = "channels";
  // Writers: the values to store, when they are another object's (an Image's or a VectorField's
  // own floats), so that a write holds no copy of them; null: `values`.
  const std::vector<float>* borrowed = nullptr;
  const std::vector<float>& data() const { return borrowed ? *borrowed : values; }

  int64_t num_voxels() const { return size[0] * size[1] * size[2]; }
  // A 3D volume with one slice counts as 2D.
  int effective_dimension() const { return ndims == 3 && size[2] == 1 ? 2 : ndims; }
};

// Stored value types. 64-bit integers (NIfTI datatypes 1024 and 1280, NRRD's long long,
// MetaImage's MET_LONG_LONG) become float as the others do: rounded once, to the nearest float.
enum class Scalar { kU8, kI8, kU16, kI16, kU32, kI32, kI64, kU64, kF32, kF64 };

// Bytes per stored value of type s.
int scalar_bytes(Scalar s);

// One stored value at p as its own type T, swapping bytes for a foreign byte order.
template <class T>
T load_as(const char* p, bool swap) {
  char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

// One stored value at p as a double, swapping bytes for a foreign byte order.
template <class T>
double load(const char* p, bool swap) {
  return static_cast<double>(load_as<T>(p, swap));
}

// Decodes `count` values of type s from raw bytes (the caller checked the length), as T (float
// or double: DICOM masks and rescales its integers in double before they are rounded once).
template <class T>
std::vector<T> decode(const char* data, int64_t count, Scalar s, bool swap);
// The same into out[0 .. count) (float).
template <class T>
void decode_into(const char* data, int64_t count, Scalar s, bool swap, T* out);

// A value rounded and clamped to [0, 255] (a label map's byte).
inline uint8_t label_byte(float value) { return uint8_t(std::lround(std::clamp(double(value), 0.0, 255.0))); }
// Values rounded and clamped to [0, 255], one byte each (label maps).
std::string label_bytes(const std::vector<float>& values);

// What writers store: for a label map its label_bytes (made in `converted`), else the values'
// own float32 bytes as they are in memory (little-endian here), without a copy. The
// view lives as long as `values` and `converted`.
inline std::string_view stored_view(const std::vector<float>& values, bool label, std::string& converted) {
  if (!label) return {reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float)};
  converted = label_bytes(values);
  return converted;
}

// Runs f with stderr sent to /dev/null: libpng and libjpeg print their own line ("libpng error:
// Read Error") before OpenCV returns an empty image, and GDCM's decoders theirs (OpenJPEG:
// "Expected a SOC marker") before it fails; the user must see only ours.
template <class F>
inline auto silenced(F&& f) {
  std::fflush(stderr);
  const int saved = ::dup(2);
  const int null = ::open("/dev/null", O_WRONLY);
  if (saved >= 0 && null >= 0) ::dup2(null, 2);
  if (null >= 0) ::close(null);
  struct Restore {
    int fd;
    ~Restore() {
      if (fd >= 0) {
        std::fflush(stderr);
        ::dup2(fd, 2);
        ::close(fd);
      }
    }
  } restore{saved};
  return f();
}

// Limits from headers: what a header declares is checked before anything is allocated.
// Deflate expands at most ~1032-fold, so compressed data cannot hold more than this many times its
// size; and the values as float must fit in the memory limit: the machine's physical memory, or
// the environment's DSNAKE_MAX_IMAGE_BYTES (bytes) when set.
inline constexpr double kMaxInflateRatio = 1100;
double image_memory_limit();
// InputError(path, key, ...) when `values` floats exceed the memory limit.
void check_declared_values(double values, const std::string& path, const std::string& key);
// InputError(path, key, ...) when `declared` bytes cannot come out of `stored` compressed bytes.
void check_inflatable(double declared, double stored, const std::string& path, const std::string& key);

// Lower-case extension, with ".nii.gz", ".inr.gz", ".hdr.gz" and ".img.gz" kept whole.
std::string extension_of(const std::string& path);

// The 2D formats that go through OpenCV.
bool is_opencv_extension(const std::string& ext);

// InputError unless `path` is an existing regular file.
void require_exists(const std::string& path);

// Whole file (or its first max_bytes) as it is on disk. MetaImage data must not go through
// gzread, which would inflate raw data that happens to start with the gzip magic bytes.
std::string read_bytes(const std::string& path, size_t max_bytes = std::string::npos);

// A text header (MetaImage, NRRD) parsed from the first 64 kB of `path`, so that a volume's data
// is not read for its header, or from the whole file when it does not end within
// them: parse(bytes) parses, ended(header, bytes) says whether the header ended within the bytes
// read. A parse of the 64 kB that throws is made again on the whole file, which gives the answer
// (or the error) a whole-file read gave.
template <class Parse, class Ended>
auto parse_header_of(const std::string& path, Parse&& parse, Ended&& ended) {
  constexpr size_t kHead = size_t(1) << 16;
  const std::string head = read_bytes(path, kHead);
  if (head.size() < kHead) return parse(head);  // the whole file
  try {
    auto h = parse(head);
    if (ended(h, head)) return h;
  } catch (const std::exception&) {  // the header may go on past the 64 kB
  }
  return parse(read_bytes(path));
}

// Reads `count` values of `type` stored from byte `offset` of `path` into `values` (cleared
// first), a block of stored values at a time (the file's bytes are never held whole;
// MetaImage and NRRD raw data). The caller checked the file holds them; a file that ends early
// all the same (it changed meanwhile) gives an InputError naming it.
void read_stored_values(const std::string& path, uint64_t offset, int64_t count, Scalar type, bool swap,
                        std::vector<float>& values);

// Whole file (or its first max_bytes) through zlib's gz reader, which gunzips .gz files and
// passes plain files through unchanged (NIfTI). `expected_bytes`: the length the caller expects
// (a header's data size; 0: unknown), read straight into a buffer of that size instead of one
// grown by doubling; a longer or shorter file is read as it is.
std::string read_gz_bytes(const std::string& path, size_t max_bytes = std::string::npos, size_t expected_bytes = 0);

// zlib- or gzip-wrapped deflate data `in` (the wrapper detected; MetaImage's CompressedData,
// NRRD's gzip encoding) decoded as it is inflated (the inflated bytes are never held
// whole): its first `skip` bytes dropped, then up to `count` values of `type` into `values`
// (cleared first, grown block by block, so memory follows the real data, never what a header
// claims). Stops at the end of the stream, after count values, or where the data ends early.
// Returns the bytes the stream held after the skip (at most count values' worth): fewer than
// count values' bytes means a truncated stream. zlib counts in 32 bits: input and output are
// handed over at most `step` bytes at a time (1 GiB; tests use a few bytes), so data beyond
// 4 GiB inflates whole. Throws InputError(path, key, "corrupt <what> data (...)") on data zlib
// refuses.
size_t inflate_values(std::string_view in, size_t skip, int64_t count, Scalar type, bool swap,
                      std::vector<float>& values, const std::string& path, const std::string& key,
                      const std::string& what, size_t step = size_t(1) << 30);
// The same for the `length` bytes of `file` from byte `offset`, read a megabyte at a time (the
// compressed bytes are not held whole either); errors name `file`.
size_t inflate_file_values(const std::string& file, uint64_t offset, uint64_t length, size_t skip, int64_t count,
                           Scalar type, bool swap, std::vector<float>& values, const std::string& key,
                           const std::string& what, size_t step = size_t(1) << 30);

// Reserves address space for `bytes` in `s` (not touched until filled) when that is at most half
// the machine's physical memory; a larger claim (a header's, larger than any volume this
// machine could hold) reserves nothing and the string grows as it is filled.
void reserve_plausible(std::string& s, size_t bytes);
void reserve_plausible(std::vector<float>& v, size_t count);  // the same for count floats

// Formats a double so that reading it back gives the same double.
std::string exact(double v);

// MetaImage (metaimage.cpp): read a .mha/.mhd completely, write one, or read only its
// header's dimension.
RawVolume read_meta(const std::string& path);
void write_meta(const RawVolume& v, const std::string& path, bool compress);
int meta_dimension(const std::string& path);

inline constexpr size_t kNiftiHeaderBytes = 348;

// The geometry RawVolume and ImageLayout share (dimensions, sizes, spacing, origin, axes),
// copied from one to the other.
template <class To, class From>
void copy_geometry(To& to, const From& from) {
  to.ndims = from.ndims;
  to.size = from.size;
  to.spacing = from.spacing;
  to.origin = from.origin;
  to.axes = from.axes;
}

// Image layouts (source_grid.cpp; image_io.h, ImageLayout): the formats that store a direction
// (MetaImage, NIfTI, NRRD), so that a volume written to them can keep its file's voxel order;
// and a volume read from `layout`'s file put back in that order and geometry (the inverse of
// align_axes), its values (all channels, its own or borrowed) through one new buffer when they
// were reordered.
bool stores_direction(const std::string& ext);
void restore_stored_order(RawVolume& v, const ImageLayout& layout);

// NIfTI (nifti.cpp). Read: NIfTI-1 and NIfTI-2, single files (.nii, .nii.gz) and .hdr/.img pairs
// (either file names the pair; each optionally gzipped); written: NIfTI-1 single files, NIfTI-2
// for a grid NIfTI-1 cannot hold (more than 32767 voxels along an axis).
// Decode a header (the geometry, placed by `transform`; with `warn`, the warning lines of
// image_io.h's NiftiTransform on stderr) from the file's first bytes (a pair's header when `path`
// is a .hdr); write float32 .nii or .nii.gz.
RawVolume decode_nifti_header(const std::string& bytes, const std::string& path,
                              NiftiTransform transform = NiftiTransform::kAuto, bool warn = false);
void write_nifti(const RawVolume& v, const std::string& path);
// The bytes before the values that write_nifti stores for v's geometry (qform and sform, codes
// 1): a NIfTI-1 header and extension flag (352 bytes), or NIfTI-2's (544) for a grid of more than
// 32767 voxels along an axis.
std::string nifti_header_of(const RawVolume& v);
// A NIfTI input's own header `source` (as stored: 348 bytes of NIfTI-1, 540 of NIfTI-2) as the
// header of a single file for values stored as uint8 (label) or float32 right after it, no
// scaling, no extensions; every other field kept. A NIfTI-1 header stays NIfTI-1 (magic "n+1",
// values from byte 352) in its byte order (`swap` says it is foreign: float32 values must then be
// stored swapped); a NIfTI-2 one becomes NIfTI-1 in native order (reals as float) when its grid
// fits NIfTI-1's int16 dim, else stays NIfTI-2 (magic "n+2", values from byte 544) in its byte
// order.
std::string nifti_header_for_values(const std::string& source, bool label, bool& swap);
// Writes parts (a header, the values) as .nii, or gzipped as .nii.gz, atomically.
void write_nifti_parts(const std::vector<std::string_view>& parts, const std::string& path);
// Reads a .nii or .nii.gz, or the .hdr/.img pair `path` names: the header first, then no more
// bytes than it declares (a gzip bomb behind a small header is not inflated), after the limits
// above; the orientation warnings on stderr. `header`, when not null, receives the header bytes
// as stored (348 for NIfTI-1, 540 for NIfTI-2).
RawVolume read_nifti(const std::string& path, NiftiTransform transform = NiftiTransform::kAuto,
                     std::string* header = nullptr);
// The dimension (2 or 3) of the NIfTI `path` names, from its header only.
int nifti_dimension(const std::string& path);
// The NIfTI extensions read_nifti reads: .nii .nii.gz, and a pair's .hdr .img .hdr.gz .img.gz.
bool is_nifti_extension(const std::string& ext);

// NRRD (nrrd.cpp): read a .nrrd (attached data) or .nhdr (detached data file) completely, or
// only its header's dimension; write float32 little-endian LPS NRRD, gzip-encoded when
// `compress` (.nrrd: data attached; .nhdr: data in <stem>.raw or <stem>.raw.gz beside it).
RawVolume read_nrrd(const std::string& path);
int nrrd_dimension(const std::string& path);
void write_nrrd(const RawVolume& v, const std::string& path, bool compress);

// gzip-wrapped deflate of `parts` one after another (nrrd.cpp; NRRD's gzip encoding, .nii.gz
// and .inr.gz), at zlib's fastest level.
std::string gzip_bytes(const std::vector<std::string_view>& parts, const std::string& path);
// The same stream handed to `put` a piece (up to 1 MB) at a time as it is made, for writers that
// stream it to their file (the compressed bytes are never held whole).
void gzip_into(const std::vector<std::string_view>& parts, const std::string& path,
               const std::function<void(std::string_view)>& put);

// INRIMAGE-4 (inr.cpp): read a .inr or .inr.gz completely, or only its header's dimension;
// write float32 little-endian (CPU=decm) .inr, or gzipped .inr.gz.
RawVolume read_inr(const std::string& path);
int inr_dimension(const std::string& path);
void write_inr(const RawVolume& v, const std::string& path);

}  // namespace dsnake::detail
