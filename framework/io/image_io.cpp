// Image and volume I/O: MetaImage (.mha/.mhd, raw or zlib), NIfTI (.nii/.nii.gz, .hdr/.img) and,
// for 2D, the OpenCV formats. Every reader decodes into one RawVolume (sizes, spacing, origin,
// channels, values as doubles), which is then checked and converted to Image<D> or
// VectorField<D>, so the checks (dimension, spacing, NaN voxels) are written once.
#include "framework/io/image_io.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/core/json_text.h"
#include "framework/io/dicom.h"
#include "framework/io/image_io_detail.h"
#include "framework/io/raster_codecs.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fcntl.h>
#include <unistd.h>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace dsnake {

namespace detail {

namespace fs = std::filesystem;

// Bytes per stored value of type s.
int scalar_bytes(Scalar s) {
  switch (s) {
    case Scalar::kU8: case Scalar::kI8: return 1;
    case Scalar::kU16: case Scalar::kI16: return 2;
    case Scalar::kU32: case Scalar::kI32: case Scalar::kF32: return 4;
    case Scalar::kI64: case Scalar::kU64: case Scalar::kF64: return 8;
  }
  return 1;
}

// Decodes `count` values of type s from raw bytes (the caller checked the length). A 64-bit
// integer is converted to T directly: through double first, one above 2^53 would be rounded
// twice and could land on another float than its nearest.
template <class T>
void decode_into(const char* data, int64_t count, Scalar s, bool swap, T* out) {
  const int nb = scalar_bytes(s);
  for (int64_t i = 0; i < count; ++i) {
    const char* p = data + i * nb;
    switch (s) {
      case Scalar::kU8: out[i] = load<uint8_t>(p, false); break;
      case Scalar::kI8: out[i] = load<int8_t>(p, false); break;
      case Scalar::kU16: out[i] = load<uint16_t>(p, swap); break;
      case Scalar::kI16: out[i] = load<int16_t>(p, swap); break;
      case Scalar::kU32: out[i] = load<uint32_t>(p, swap); break;
      case Scalar::kI32: out[i] = load<int32_t>(p, swap); break;
      case Scalar::kI64: out[i] = static_cast<T>(load_as<int64_t>(p, swap)); break;
      case Scalar::kU64: out[i] = static_cast<T>(load_as<uint64_t>(p, swap)); break;
      case Scalar::kF32: out[i] = load<float>(p, swap); break;
      case Scalar::kF64: out[i] = load<double>(p, swap); break;
    }
  }
}
template void decode_into<float>(const char*, int64_t, Scalar, bool, float*);

template <class T>
std::vector<T> decode(const char* data, int64_t count, Scalar s, bool swap) {
  std::vector<T> out(count);
  decode_into(data, count, s, swap, out.data());
  return out;
}
template std::vector<float> decode<float>(const char*, int64_t, Scalar, bool);
template std::vector<double> decode<double>(const char*, int64_t, Scalar, bool);

// Values rounded and clamped to [0, 255], one byte each (label maps).
std::string label_bytes(const std::vector<float>& values) {
  std::string out(values.size(), '\0');
  for (size_t i = 0; i < values.size(); ++i) out[i] = char(label_byte(values[i]));
  return out;
}

// Lower-case extension, with ".nii.gz", ".inr.gz", ".hdr.gz" and ".img.gz" kept whole.
std::string extension_of(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* two : {".nii.gz", ".inr.gz", ".hdr.gz", ".img.gz"})
    if (name.size() > 7 && name.ends_with(two)) return two;
  const size_t dot = name.rfind('.');
  return dot == std::string::npos ? "" : name.substr(dot);
}

bool is_nifti_extension(const std::string& ext) {
  return ext == ".nii" || ext == ".nii.gz" || ext == ".hdr" || ext == ".img" || ext == ".hdr.gz" || ext == ".img.gz";
}

// The 2D formats that go through OpenCV.
bool is_opencv_extension(const std::string& ext) {
  return ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp";
}

[[noreturn]] void unknown_format(const std::string& path) {
  throw InputError(path, "", "unknown image format (expected .mha, .mhd, .nii, .nii.gz, a NIfTI pair .hdr/.img, .nrrd, "
                             ".nhdr, .inr, .inr.gz, DICOM (.dcm, .dicom, a series folder), or for 2D .png, .tif, .tiff, "
                             ".jpg, .jpeg, .bmp)");
}

// InputError unless `path` is an existing regular file.
void require_exists(const std::string& path) { require_regular_file(path, "image file"); }

// Whole file (or its first max_bytes) as it is on disk. MetaImage data must not go through
// gzread, which would inflate raw data that happens to start with the gzip magic bytes.
std::string read_bytes(const std::string& path, size_t max_bytes) {
  require_exists(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open file");
  // Sized from the file's length first, so that a volume is read into one buffer of its size
  // (appending would grow it by doubling, allocating and copying several times its size);
  // then read on in blocks, in case the file grew or its length was not known.
  std::string s;
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > 0) {
    s.resize(size_t(std::min<uintmax_t>(size, max_bytes)));
    in.read(s.data(), std::streamsize(s.size()));
    s.resize(size_t(in.gcount()));
  }
  char buf[1 << 16];
  while (s.size() < max_bytes && in) {
    in.read(buf, sizeof(buf));
    if (in.gcount() <= 0) break;
    s.append(buf, size_t(in.gcount()));
  }
  if (s.size() > max_bytes) s.resize(max_bytes);
  return s;
}

void read_stored_values(const std::string& path, uint64_t offset, int64_t count, Scalar type, bool swap,
                        std::vector<float>& values) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open file");
  in.seekg(std::streamoff(offset));
  const size_t nb = size_t(scalar_bytes(type));
  constexpr size_t kBlockValues = size_t(1) << 17;  // at most 1 MB of stored values at a time
  std::vector<char> block(std::min(size_t(count), kBlockValues) * nb);
  values.clear();
  values.reserve(size_t(count));
  while (int64_t(values.size()) < count) {
    const size_t m = std::min(size_t(count) - values.size(), kBlockValues);
    in.read(block.data(), std::streamsize(m * nb));
    if (size_t(in.gcount()) != m * nb)
      throw InputError(path, "", "the data ended early while it was read (the file changed?)");
    const size_t at = values.size();
    values.resize(at + m);
    decode_into(block.data(), int64_t(m), type, swap, values.data() + at);
  }
}

double image_memory_limit() {
  if (const char* env = std::getenv("DSNAKE_MAX_IMAGE_BYTES")) {
    char* end = nullptr;
    const double v = std::strtod(env, &end);
    if (end != env && v > 0) return v;
  }
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 1e12;
}

void check_declared_values(double values, const std::string& path, const std::string& key) {
  const double bytes = values * sizeof(float), limit = image_memory_limit();
  if (!(bytes <= limit))
    throw InputError(path, key, "declares " + exact(values) + " values: " + exact(bytes / 1e9) +
                                    " GB as float, more than the memory limit of " + exact(limit / 1e9) +
                                    " GB (the machine's memory, or DSNAKE_MAX_IMAGE_BYTES)");
}

void check_inflatable(double declared, double stored, const std::string& path, const std::string& key) {
  if (declared > kMaxInflateRatio * stored + 1024)
    throw InputError(path, key, "declares " + exact(declared) + " bytes of data, more than deflate can expand the " +
                                    exact(stored) + " compressed bytes the file holds to");
}

namespace {

// Reserves room for n elements of c when their bytes are at most half the machine's memory.
template <class Container>
void reserve_plausible_elements(Container& c, size_t n) {
  static const size_t half_memory = [] {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? size_t(pages) * size_t(page) / 2 : size_t(1) << 30;
  }();
  if (n > half_memory / sizeof(typename Container::value_type)) return;
  try {
    c.reserve(n);
  } catch (const std::exception&) {  // (std::bad_alloc: the system refuses) grown as it is filled
  }
}

}  // namespace

void reserve_plausible(std::string& s, size_t bytes) { reserve_plausible_elements(s, bytes); }
void reserve_plausible(std::vector<float>& v, size_t count) { reserve_plausible_elements(v, count); }

namespace {

// inflate_values with its input from next(most): a view of at most `most` further bytes of the
// deflate data (zlib or gzip wrapper), empty at the end. zlib fills a window of at most `step`
// bytes (and 4 MB) after the bytes of a partial value carried over from the last window; the
// whole values are decoded and the rest carried.
template <class Next>
size_t inflate_values_from(Next&& next, size_t skip, int64_t count, Scalar type, bool swap, std::vector<float>& values,
                           const std::string& path, const std::string& key, const std::string& what, size_t step) {
  step = std::max<size_t>(step, 1);
  const size_t nb = size_t(scalar_bytes(type)), limit = skip + size_t(count) * nb;
  values.clear();
  reserve_plausible(values, size_t(count));
  std::vector<char> buffer;  // a partial value carried over, then the window zlib fills
  size_t carried = 0;        // bytes of a partial value at the buffer's start
  size_t to_skip = skip;
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw std::runtime_error("zlib initialisation failed");
  size_t total = 0;  // bytes inflated
  int ret = Z_OK;
  while (total < limit && ret != Z_STREAM_END) {
    if (zs.avail_in == 0) {
      const std::string_view piece = next(step);
      zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(piece.data()));
      zs.avail_in = static_cast<uInt>(piece.size());
    }
    const size_t room = std::min({limit - total, size_t(1) << 22, step});
    buffer.resize(carried + room);
    zs.next_out = reinterpret_cast<Bytef*>(buffer.data() + carried);
    zs.avail_out = static_cast<uInt>(room);
    ret = inflate(&zs, Z_NO_FLUSH);
    const size_t n = room - zs.avail_out;
    total += n;
    const char* p = buffer.data();
    size_t have = carried + n;
    if (to_skip > 0) {  // (skipped bytes never come after a carried partial value)
      const size_t dropped = std::min(to_skip, n);
      to_skip -= dropped, p += dropped, have -= dropped;
    }
    const size_t whole = std::min(have / nb, size_t(count) - values.size());
    const size_t at = values.size();
    values.resize(at + whole);
    decode_into(p, int64_t(whole), type, swap, values.data() + at);
    carried = have - whole * nb;
    std::memmove(buffer.data(), p + whole * nb, carried);
    // (Z_BUF_ERROR: no progress possible, every input byte given and the stream not ended.)
    if (ret != Z_OK && ret != Z_STREAM_END) break;
  }
  const std::string msg = zs.msg ? zs.msg : "";
  inflateEnd(&zs);
  if (ret == Z_DATA_ERROR || ret == Z_NEED_DICT || ret == Z_MEM_ERROR || ret == Z_STREAM_ERROR)
    throw InputError(path, key, "corrupt " + what + " data (" + (msg.empty() ? std::string("error") : msg) + ")");
  return values.size() * nb + carried;
}

}  // namespace

size_t inflate_values(std::string_view in, size_t skip, int64_t count, Scalar type, bool swap,
                      std::vector<float>& values, const std::string& path, const std::string& key,
                      const std::string& what, size_t step) {
  size_t fed = 0;
  auto next = [&](size_t most) {
    const std::string_view piece = in.substr(fed, most);
    fed += piece.size();
    return piece;
  };
  return inflate_values_from(next, skip, count, type, swap, values, path, key, what, step);
}

size_t inflate_file_values(const std::string& file, uint64_t offset, uint64_t length, size_t skip, int64_t count,
                           Scalar type, bool swap, std::vector<float>& values, const std::string& key,
                           const std::string& what, size_t step) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file, "", "cannot open file");
  in.seekg(std::streamoff(offset));
  std::vector<char> block(size_t(std::min<uint64_t>(length, uint64_t(1) << 20)));
  uint64_t left = length;
  auto next = [&](size_t most) {
    const size_t n = size_t(std::min<uint64_t>({left, most, block.size()}));
    in.read(block.data(), std::streamsize(n));
    const size_t got = size_t(in.gcount());
    left = got == n ? left - got : 0;  // a file that ended early ends the stream
    return std::string_view(block.data(), got);
  };
  return inflate_values_from(next, skip, count, type, swap, values, file, key, what, step);
}

// Whole file (or its first max_bytes) through zlib's gz reader, which gunzips .gz files and
// passes plain files through unchanged (NIfTI).
std::string read_gz_bytes(const std::string& path, size_t max_bytes, size_t expected_bytes) {
  require_exists(path);
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw InputError(path, "", "cannot open file");
  std::string s;
  if (const size_t want = std::min(max_bytes, expected_bytes); want > 0) {
    // Reserved (address space only), then filled in steps that double from 1 MB, so that what
    // is touched stays within twice what the file really holds, whatever its header claims.
    reserve_plausible(s, want);
    size_t got = 0;
    while (got < want) {
      const size_t step = std::min({want - got, std::max(got, size_t(1) << 20), size_t(1) << 30});
      s.resize(got + step);
      const int n = gzread(f, s.data() + got, unsigned(step));
      if (n < 0) {
        gzclose(f);
        throw InputError(path, "", "corrupt gzip data");
      }
      got += size_t(n);
      if (n == 0) break;
    }
    s.resize(got);
  }
  char buf[1 << 16];
  while (s.size() < max_bytes) {
    const int n = gzread(f, buf, sizeof(buf));
    if (n < 0) {
      gzclose(f);
      throw InputError(path, "", "corrupt gzip data");
    }
    if (n == 0) break;
    s.append(buf, static_cast<size_t>(n));
  }
  gzclose(f);
  if (s.size() > max_bytes) s.resize(max_bytes);
  return s;
}

// Formats a double so that reading it back gives the same double.
std::string exact(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

}  // namespace detail

namespace {

using namespace detail;
namespace fs = std::filesystem;

// ---------------------------------------------------------------- OpenCV (2D)

// A 2D grey image through OpenCV; colour is converted to grey, 8/16-bit and float kept.
// True if the file begins like PNG, JPEG, BMP or TIFF (BigTIFF too). OpenCV picks its decoder by
// content, not by name, and some of its decoders (GDCM's for DICOM, found by fuzzing)
// abort the process on a malformed file: only these four formats are handed to it.
bool has_raster_signature(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char b[8] = {};
  in.read(b, sizeof b);
  const std::string head(b, size_t(in.gcount()));
  auto starts = [&](const std::string& magic) { return head.compare(0, magic.size(), magic) == 0; };
  return starts("\x89PNG\r\n\x1a\n") || starts("\xff\xd8\xff") || starts("BM") ||
         starts(std::string("II*\0", 4)) || starts(std::string("MM\0*", 4)) || starts(std::string("II+\0", 4)) ||
         starts(std::string("MM\0+", 4));
}

RawVolume read_opencv(const std::string& path) {
  require_exists(path);
  if (!has_raster_signature(path))
    throw InputError(path, "", "the content is not PNG, JPEG, BMP or TIFF (its first bytes do not match any of them)");
  cv::Mat m;
  try {
    m = silenced([&] { return read_raster(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE); });
  } catch (const cv::Exception& e) {  // OpenCV's own checks (a BMP declaring 2^30 columns: fuzzing)
    throw InputError(path, "", "cannot decode the image (OpenCV: " + e.err + ")");
  }
  if (m.empty()) throw InputError(path, "", "cannot decode the image");
  // Converted straight into the volume's floats (OpenCV writes into a Mat over them, row by row,
  // x fastest): the decoded pixels and the floats are all a read holds, no copy in double
  // between them. Every stored type converts to the float nearest its value, as it did through
  // double (double holds every one of them exactly).
  RawVolume v;
  v.ndims = 2;
  v.size = {m.cols, m.rows, 1};
  v.values.resize(size_t(m.cols) * size_t(m.rows));
  cv::Mat values(m.rows, m.cols, CV_32F, v.values.data());
  m.convertTo(values, CV_32F);
  DSNAKE_ASSERT(values.data == reinterpret_cast<uchar*>(v.values.data()), "OpenCV converted into a buffer of its own");
  return v;
}

// Writes 8-bit grey after clamping to [0, 255] (spacing and origin are lost).
void write_opencv(const RawVolume& v, const std::string& path) {
  cv::Mat m(int(v.size[1]), int(v.size[0]), CV_8U);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x)
      m.at<uint8_t>(y, x) = uint8_t(std::lround(std::clamp(double(v.data()[size_t(y) * m.cols + x]), 0.0, 255.0)));
  write_via_temporary(path, [&](const std::string& tmp) {
    if (!write_raster(tmp, m)) throw OutputError(path, "OpenCV cannot write the image");
  });
}

// ---------------------------------------------------------------- dispatch and checks

// For each index axis a, the world axis it runs along and its sign; false if some axis is
// oblique (no world axis within 1e-4 of it) or two index axes share a world axis.
bool signed_permutation(const RawVolume& v, std::array<int, 3>& world_axis, std::array<int, 3>& sign) {
  std::array<bool, 3> used{false, false, false};
  for (int a = 0; a < v.ndims; ++a) {
    int k = 0;
    for (int b = 1; b < v.ndims; ++b)
      if (std::abs(v.axes[a][b]) > std::abs(v.axes[a][k])) k = b;
    double off = 0;
    for (int b = 0; b < v.ndims; ++b)
      if (b != k) off = std::max(off, std::abs(v.axes[a][b]));
    if (!(std::abs(std::abs(v.axes[a][k]) - 1) <= 1e-4 && off <= 1e-4) || used[k]) return false;
    used[k] = true;
    world_axis[a] = k;
    sign[a] = v.axes[a][k] > 0 ? 1 : -1;
  }
  return true;
}

// Reverses index axis a in place: the voxel order along a, and the origin moves to what was
// the last voxel, so every voxel keeps its world position and the axis direction is negated.
void reverse_axis(RawVolume& v, int a) {
  const int64_t n = v.size[a];
  for (int k = 0; k < 3; ++k) v.origin[k] += v.axes[a][k] * v.spacing[a] * double(n - 1);
  for (int k = 0; k < 3; ++k) v.axes[a][k] = -v.axes[a][k];
  const int64_t stride = a == 0 ? 1 : a == 1 ? v.size[0] : v.size[0] * v.size[1];
  const int c = v.channels;
  for (int64_t l = 0; l < v.num_voxels(); ++l) {
    const int64_t i = (l / stride) % n;
    if (i >= n - 1 - i) continue;  // each pair once
    const int64_t m = l + (n - 1 - 2 * i) * stride;
    for (int k = 0; k < c; ++k) std::swap(v.values[l * c + k], v.values[m * c + k]);
  }
}

// The direction cosines as a rotation: checks that they are orthonormal (to 1e-3; a sheared
// grid, as from a CT gantry tilt, is refused), and snaps them to the nearest orthonormal matrix.
void orthonormalize_axes(RawVolume& v, const std::string& path) {
  const int n = v.ndims;
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  for (int a = 0; a < n; ++a)
    for (int k = 0; k < n; ++k) m(k, a) = v.axes[a][k];
  const Eigen::Matrix3d gram = m.transpose() * m;
  if (!m.allFinite() || (gram - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-3)
    throw InputError(path, "direction", "the axis directions are not orthonormal (a sheared grid, e.g. a CT "
                                        "gantry tilt): resample the image onto an orthogonal grid first");
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  for (int a = 0; a < n; ++a)
    for (int k = 0; k < n; ++k) v.axes[a][k] = r(k, a);
}

// Refuses a NaN or infinite value, naming its voxel by its index in the file as stored (i, j, k:
// the order nibabel, ITK and Slicer show), before align_axes reorders the axes.
void check_finite(const RawVolume& v, const std::string& path) {
  const int c = std::max(1, v.channels);
  for (size_t i = 0; i < v.values.size(); ++i) {
    if (std::isfinite(v.values[i])) continue;
    const int64_t l = int64_t(i) / c;
    const int64_t idx[3] = {l % v.size[0], (l / v.size[0]) % v.size[1], l / (v.size[0] * v.size[1])};
    std::string where = "voxel (";
    for (int a = 0; a < v.effective_dimension(); ++a) where += (a ? ", " : "") + std::to_string(idx[a]);
    if (c > 1) where += ") component (" + std::to_string(int64_t(i) % c);
    throw InputError(path, where + ")", std::isnan(v.values[i]) ? "value is NaN"
                                                                : "value is infinite or beyond float's range (3.4e38)");
  }
}

// Reorders a volume whose index axes are a signed permutation of the world axes (flipped or
// permuted axes, the common case) so that index axis a runs along +world axis a: the same voxel
// lands at the same world position, and the grid is axis-aligned. An oblique direction (a true
// rotation) is kept as the grid's direction (image.h: the framework works in the grid's frame);
// if it is a reflection (determinant -1), the last index axis is reversed so that it becomes a
// rotation, which keeps the frame's orientation and so the templates' outward normals.
// A 2D image taken from a 3D file must lie in the x-y plane; an oblique one is refused.
// `layout` (when not null) receives the stored geometry and the reordering.
void align_axes(RawVolume& v, const std::string& path, ImageLayout* layout) {
  if (layout) copy_geometry(*layout, v);
  if (v.effective_dimension() == 2 && v.ndims == 3) {
    if (std::abs(std::abs(v.axes[2][2]) - 1) > 1e-4 || std::abs(v.axes[0][2]) > 1e-4 || std::abs(v.axes[1][2]) > 1e-4)
      throw InputError(path, "direction", "a single-slice image whose plane is not the world's x-y plane cannot be "
                                          "read as 2D; read it as a 3D volume");
    v.ndims = 2;
    v.axes[2] = {0, 0, 1};
  }
  orthonormalize_axes(v, path);
  std::array<int, 3> to{0, 1, 2}, sign{1, 1, 1};
  if (!signed_permutation(v, to, sign)) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    for (int a = 0; a < v.ndims; ++a)
      for (int k = 0; k < v.ndims; ++k) m(k, a) = v.axes[a][k];
    if (m.determinant() < 0) {
      reverse_axis(v, v.ndims - 1);
      if (layout) layout->sign[v.ndims - 1] = -1;
    }
    return;
  }
  if (layout) layout->to = to, layout->sign = sign;
  bool identity = true;
  for (int a = 0; a < v.ndims; ++a) identity &= to[a] == a && sign[a] == 1;
  if (identity) return;
  RawVolume out = v;
  for (int a = 0; a < v.ndims; ++a) {
    out.size[to[a]] = v.size[a];
    out.spacing[to[a]] = v.spacing[a];
    // world coordinate of the voxel that becomes index 0 along world axis to[a]
    out.origin[to[a]] = v.origin[to[a]] + (sign[a] < 0 ? -v.spacing[a] * double(v.size[a] - 1) : 0.0);
  }
  for (int a = 0; a < 3; ++a) out.axes[a] = {a == 0 ? 1.0 : 0.0, a == 1 ? 1.0 : 0.0, a == 2 ? 1.0 : 0.0};
  const int c = v.channels;
  for (int64_t l = 0; l < v.num_voxels(); ++l) {
    const int64_t idx[3] = {l % v.size[0], (l / v.size[0]) % v.size[1], l / (v.size[0] * v.size[1])};
    int64_t j[3] = {0, 0, 0};
    for (int a = 0; a < v.ndims; ++a) j[to[a]] = sign[a] > 0 ? idx[a] : v.size[a] - 1 - idx[a];
    const int64_t m = j[0] + out.size[0] * (j[1] + out.size[1] * j[2]);
    for (int k = 0; k < c; ++k) out.values[m * c + k] = v.values[l * c + k];
  }
  v = std::move(out);
}

// Decodes any supported file by its extension, its axes aligned with the world's; `layout`
// (when not null) receives how the file stores its voxels.
RawVolume read_volume(const std::string& path, const ImageReadOptions& options = {}, ImageLayout* layout = nullptr) {
  const std::string ext = extension_of(path);
  RawVolume v;
  if (layout) {
    *layout = ImageLayout();
    layout->path = path;
  }
  if (ext == ".mha" || ext == ".mhd") v = read_meta(path);
  else if (is_nifti_extension(ext))
    v = read_nifti(path, options.nifti_transform, layout ? &layout->nifti_header : nullptr);
  else if (ext == ".nrrd" || ext == ".nhdr") v = read_nrrd(path);
  else if (ext == ".inr" || ext == ".inr.gz") v = read_inr(path);
  else if (is_opencv_extension(ext)) {
    v = read_opencv(path);
    check_finite(v, path);
    if (layout) layout->ndims = 2, layout->size = v.size;
    return v;
  }
  else if (is_dicom_path(path)) v = read_dicom(path);
  else unknown_format(path);
  check_finite(v, path);
  align_axes(v, path, layout);
  return v;
}

// Writes any supported format by its extension.
void write_volume(const RawVolume& v, const std::string& path, const ImageWriteOptions& options) {
  const std::string ext = extension_of(path);
  if (ext == ".mha" || ext == ".mhd") return write_meta(v, path, options.compress);
  if (ext == ".nii" || ext == ".nii.gz") return write_nifti(v, path);
  if (is_nifti_extension(ext))
    throw InputError(path, "", "NIfTI pairs (.hdr + .img) are read, not written: write .nii or .nii.gz");
  if (ext == ".nrrd" || ext == ".nhdr") return write_nrrd(v, path, options.compress);
  if (ext == ".inr" || ext == ".inr.gz") return write_inr(v, path);
  if (is_opencv_extension(ext) && v.ndims == 2 && v.channels == 1) return write_opencv(v, path);
  if (is_opencv_extension(ext)) throw InputError(path, "", "this format holds only 2D grey images");
  unknown_format(path);
}

// The grid of a decoded volume as Grid<D>, after checking dimension, channels and spacing.
template <int D>
Grid<D> checked_grid(const RawVolume& v, const std::string& path, int channels) {
  const int found = v.effective_dimension();
  if (found != D)
    throw InputError(path, v.dim_key, "expected a " + std::to_string(D) + "D image, found " + std::to_string(found) + "D");
  if (v.channels != channels)
    throw InputError(path, v.channel_key, "expected " + std::to_string(channels) + " component(s) per voxel, found " +
                                              std::to_string(v.channels));
  Grid<D> g;
  for (int a = 0; a < D; ++a) {
    if (!(v.spacing[a] > 0) || !std::isfinite(v.spacing[a]))
      throw InputError(path, v.spacing_key, "spacing must be positive, found " + exact(v.spacing[a]));
    if (!std::isfinite(v.origin[a])) throw InputError(path, "origin", "origin must be finite");
    g.size[a] = int(v.size[a]);
    g.spacing[a] = v.spacing[a];
    g.origin[a] = v.origin[a];
    for (int k = 0; k < D; ++k) g.direction(k, a) = v.axes[a][k];
  }
  return g;
}

// An empty RawVolume with the geometry of a grid.
template <int D>
RawVolume raw_of(const Grid<D>& g, int channels) {
  RawVolume v;
  v.ndims = D;
  v.channels = channels;
  for (int a = 0; a < D; ++a) {
    v.size[a] = g.size[a];
    v.spacing[a] = g.spacing[a];
    v.origin[a] = g.origin[a];
    for (int k = 0; k < D; ++k) v.axes[a][k] = g.direction(k, a);
  }
  return v;
}

}  // namespace

bool is_dicom_input(const std::string& path) { return is_dicom_path(path); }

// Reads only the header (MetaImage, NIfTI, NRRD, INRIMAGE, DICOM); OpenCV formats are 2D.
int image_file_dimension(const std::string& path) {
  const std::string ext = extension_of(path);
  if (ext == ".mha" || ext == ".mhd") return meta_dimension(path);
  if (is_nifti_extension(ext)) return nifti_dimension(path);
  if (ext == ".nrrd" || ext == ".nhdr") return nrrd_dimension(path);
  if (ext == ".inr" || ext == ".inr.gz") return inr_dimension(path);
  if (is_opencv_extension(ext)) return 2;
  if (is_dicom_path(path)) return dicom_dimension(path);
  unknown_format(path);
}

// Decodes, checks (dimension, one channel, spacing, finite voxels) and converts to float.
template <int D>
Image<D> read_image(const std::string& path, const ImageReadOptions& options, ImageLayout* layout) {
  RawVolume v = read_volume(path, options, layout);
  const Grid<D> grid = checked_grid<D>(v, path, 1);
  return Image<D>(grid, std::move(v.values));  // the decoded floats are the image's (same size: checked_grid)
}

template <int D>
Image<D> read_image(const std::string& path, const ImageReadOptions& options) {
  return read_image<D>(path, options, nullptr);
}

template <int D>
Image<D> read_image(const std::string& path) {
  return read_image<D>(path, ImageReadOptions{}, nullptr);
}

// Stores the grid and the voxels through the shared RawVolume writer.
template <int D>
void write_image(const Image<D>& image, const std::string& path, const ImageWriteOptions& options) {
  RawVolume v = raw_of<D>(image.grid(), 1);
  v.borrowed = &image.data();
  v.label = options.label;
  write_volume(v, path, options);
}

// Default options: uncompressed.
template <int D>
void write_image(const Image<D>& image, const std::string& path) {
  write_image<D>(image, path, ImageWriteOptions{});
}

// Vector fields go to MetaImage (channels), NIfTI (intent vector), NRRD (vector axis) or
// INRIMAGE (VDIM) only.
// `layout`: null, or the file whose grid the field is on (written in its order where the format can).
template <int D>
void write_vector_field_to(const VectorField<D>& field, const std::string& path, const ImageLayout* layout) {
  RawVolume v = raw_of<D>(field.grid(), D);
  const auto& r = field.grid().direction;  // frame components -> world components (as ITK stores them)
  const bool rotate = !field.grid().axis_aligned();
  if (!rotate) v.borrowed = &field.data();  // stored as they are: no copy
  else v.values.resize(size_t(field.num_voxels()) * D);
  for (int64_t i = 0; rotate && i < field.num_voxels(); ++i) {
    const Point<D> w = rotate ? Point<D>(r * field[i]) : field[i];
    for (int a = 0; a < D; ++a) v.values[size_t(i) * D + a] = float(w[a]);
  }
  const std::string ext = extension_of(path);
  if (is_opencv_extension(ext)) throw InputError(path, "", "vector fields need .mha, .mhd, .nii, .nii.gz, .nrrd, .nhdr, .inr or .inr.gz");
  if (layout && stores_direction(ext)) restore_stored_order(v, *layout);
  write_volume(v, path, ImageWriteOptions{});
}

template <int D>
void write_vector_field(const VectorField<D>& field, const std::string& path) {
  write_vector_field_to<D>(field, path, nullptr);
}

template <int D>
void write_vector_field(const VectorField<D>& field, const std::string& path, const ImageLayout& layout) {
  write_vector_field_to<D>(field, path, &layout);
}

// As read_image, with D interleaved components per voxel (world components; rotated into the
// grid's frame for an oblique grid).
template <int D>
VectorField<D> read_vector_field(const std::string& path) {
  const RawVolume v = read_volume(path);
  VectorField<D> field(checked_grid<D>(v, path, D));
  const auto& r = field.grid().direction;  // world components -> the grid frame's
  const bool rotate = !field.grid().axis_aligned();
  for (int64_t i = 0; i < field.num_voxels(); ++i) {
    Point<D> w;
    for (int a = 0; a < D; ++a) w[a] = v.values[size_t(i) * D + a];
    field[i] = rotate ? Point<D>(r.transpose() * w) : w;
  }
  return field;
}

// Decodes `in` as read_volume does, checks it as read_image/read_vector_field would, and
// writes it to `out` with its geometry (spacing, origin, axes) as float32 voxels.
void convert_image_file(const std::string& in, const std::string& out, const ImageWriteOptions& options,
                        const ImageReadOptions& read_options) {
  ImageLayout layout;
  RawVolume v = read_volume(in, read_options, &layout);
  const int d = v.effective_dimension();
  if (d == 2) checked_grid<2>(v, in, v.channels == 2 ? 2 : 1);
  else checked_grid<3>(v, in, v.channels == 3 ? 3 : 1);
  const std::string ext = extension_of(out);
  // Formats that store a direction get the input's own voxel order and axes; INRIMAGE and the
  // raster formats, which store none, the axis-aligned grid read_volume made.
  if (stores_direction(ext)) restore_stored_order(v, layout);
  if (d == 2 && is_opencv_extension(ext)) v.ndims = 2;  // a one-slice volume to PNG
  write_volume(v, out, options);
}

template Image<2> read_image<2>(const std::string&);
template Image<3> read_image<3>(const std::string&);
template Image<2> read_image<2>(const std::string&, const ImageReadOptions&);
template Image<3> read_image<3>(const std::string&, const ImageReadOptions&);
template Image<2> read_image<2>(const std::string&, const ImageReadOptions&, ImageLayout*);
template Image<3> read_image<3>(const std::string&, const ImageReadOptions&, ImageLayout*);
template void write_image<2>(const Image<2>&, const std::string&);
template void write_image<3>(const Image<3>&, const std::string&);
template void write_image<2>(const Image<2>&, const std::string&, const ImageWriteOptions&);
template void write_image<3>(const Image<3>&, const std::string&, const ImageWriteOptions&);
template void write_vector_field<2>(const VectorField<2>&, const std::string&);
template void write_vector_field<3>(const VectorField<3>&, const std::string&);
template void write_vector_field<2>(const VectorField<2>&, const std::string&, const ImageLayout&);
template void write_vector_field<3>(const VectorField<3>&, const std::string&, const ImageLayout&);
template VectorField<2> read_vector_field<2>(const std::string&);
template VectorField<3> read_vector_field<3>(const std::string&);

}  // namespace dsnake

