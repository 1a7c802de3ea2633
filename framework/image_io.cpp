// Image and volume I/O: MetaImage (.mha/.mhd, raw or zlib), NIfTI-1 (.nii/.nii.gz) and, for
// 2D, the OpenCV formats. Every reader decodes into one RawVolume (sizes, spacing, origin,
// channels, values as doubles), which is then checked and converted to Image<D> or
// VectorField<D>, so the checks (dimension, spacing, NaN voxels) are written once.
#include "framework/image_io.h"

#include "framework/atomic_file.h"
#include "framework/errors.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace dsnake {

namespace {

namespace fs = std::filesystem;

// A decoded image of any supported format, before the checks for one dimension D.
struct RawVolume {
  int ndims = 3;                              // spatial dimensions as stored (2 or 3)
  std::array<int64_t, 3> size{1, 1, 1};       // voxels per axis (unused axes: 1)
  std::array<double, 3> spacing{1, 1, 1};     // physical voxel size per axis
  std::array<double, 3> origin{0, 0, 0};      // physical position of voxel 0
  int channels = 1;                           // 1 for an image, D for a vector field
  std::vector<double> values;                 // voxel-major (x fastest), channels interleaved
  std::string dim_key = "dimension", spacing_key = "spacing", channel_key = "channels";

  int64_t num_voxels() const { return size[0] * size[1] * size[2]; }
  // A 3D volume with one slice counts as 2D.
  int effective_dimension() const { return ndims == 3 && size[2] == 1 ? 2 : ndims; }
};

enum class Scalar { kU8, kI8, kU16, kI16, kU32, kI32, kF32, kF64 };

// Bytes per stored value of type s.
int scalar_bytes(Scalar s) {
  switch (s) {
    case Scalar::kU8: case Scalar::kI8: return 1;
    case Scalar::kU16: case Scalar::kI16: return 2;
    case Scalar::kU32: case Scalar::kI32: case Scalar::kF32: return 4;
    case Scalar::kF64: return 8;
  }
  return 1;
}

// One stored value at p as a double, swapping bytes for a foreign byte order.
template <class T>
double load(const char* p, bool swap) {
  char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return static_cast<double>(v);
}

// Decodes `count` values of type s from raw bytes (the caller checked the length).
std::vector<double> decode(const char* data, int64_t count, Scalar s, bool swap) {
  std::vector<double> out(count);
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
      case Scalar::kF32: out[i] = load<float>(p, swap); break;
      case Scalar::kF64: out[i] = load<double>(p, swap); break;
    }
  }
  return out;
}

// Values as little-endian float32 bytes (the format every writer stores).
std::string float_bytes(const std::vector<double>& values) {
  std::string out(values.size() * 4, '\0');
  for (size_t i = 0; i < values.size(); ++i) {
    const float f = static_cast<float>(values[i]);
    std::memcpy(out.data() + 4 * i, &f, 4);
  }
  return out;
}

// Lower-case extension, with ".nii.gz" kept whole.
std::string extension_of(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  if (name.size() > 7 && name.ends_with(".nii.gz")) return ".nii.gz";
  const size_t dot = name.rfind('.');
  return dot == std::string::npos ? "" : name.substr(dot);
}

// The 2D formats that go through OpenCV.
bool is_opencv_extension(const std::string& ext) {
  return ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp";
}

[[noreturn]] void unknown_format(const std::string& path) {
  throw InputError(path, "", "unknown image format (expected .mha, .mhd, .nii, .nii.gz, or for 2D "
                             ".png, .tif, .tiff, .jpg, .jpeg, .bmp)");
}

// InputError unless `path` is an existing regular file.
void require_exists(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "", "file not found");
}

// Whole file (or its first max_bytes) as it is on disk. MetaImage data must not go through
// gzread, which would inflate raw data that happens to start with the gzip magic bytes.
std::string read_bytes(const std::string& path, size_t max_bytes = std::string::npos) {
  require_exists(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open file");
  std::string s;
  char buf[1 << 16];
  while (s.size() < max_bytes) {
    in.read(buf, sizeof(buf));
    if (in.gcount() <= 0) break;
    s.append(buf, size_t(in.gcount()));
  }
  if (s.size() > max_bytes) s.resize(max_bytes);
  return s;
}

// Whole file (or its first max_bytes) through zlib's gz reader, which gunzips .gz files and
// passes plain files through unchanged (NIfTI).
std::string read_gz_bytes(const std::string& path, size_t max_bytes = std::string::npos) {
  require_exists(path);
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw InputError(path, "", "cannot open file");
  std::string s;
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

// ---------------------------------------------------------------- MetaImage

struct MetaHeader {
  std::map<std::string, std::string> keys;
  size_t data_start = 0;  // byte just past the ElementDataFile line
};

// s without leading and trailing blanks.
std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  const size_t b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// "Key = Value" lines up to ElementDataFile (which ends a MetaImage header).
MetaHeader parse_meta_header(const std::string& bytes, const std::string& path) {
  MetaHeader h;
  size_t pos = 0;
  int line_no = 0;
  while (pos < bytes.size()) {
    size_t end = bytes.find('\n', pos);
    const size_t next = end == std::string::npos ? bytes.size() : end + 1;
    if (end == std::string::npos) end = bytes.size();
    const std::string line = trim(bytes.substr(pos, end - pos));
    ++line_no;
    pos = next;
    if (line.empty()) continue;
    const size_t eq = line.find('=');
    if (eq == std::string::npos || line.size() > 4096)
      throw InputError(path, "header line " + std::to_string(line_no), "unreadable header: expected 'Key = Value'");
    const std::string key = trim(line.substr(0, eq));
    h.keys[key] = trim(line.substr(eq + 1));
    if (key == "ElementDataFile") {
      h.data_start = pos;
      return h;
    }
  }
  throw InputError(path, "ElementDataFile", "missing required key");
}

// The value of the first of `names` present in the header, or null.
const std::string* find_key(const MetaHeader& h, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    auto it = h.keys.find(n);
    if (it != h.keys.end()) return &it->second;
  }
  return nullptr;
}

// The numbers of a key's value; exactly `count` of them unless count < 0.
std::vector<double> meta_numbers(const std::string& value, const std::string& path, const std::string& key,
                                 int count) {
  std::istringstream in(value);
  std::vector<double> v;
  std::string tok;
  while (in >> tok) {
    char* end = nullptr;
    const double d = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') throw InputError(path, key, "expected numbers, found '" + value + "'");
    v.push_back(d);
  }
  if (count >= 0 && int(v.size()) != count)
    throw InputError(path, key, "expected " + std::to_string(count) + " numbers, found " + std::to_string(v.size()));
  return v;
}

// A MetaImage boolean ("True"/"False") that may be absent (false).
bool meta_true(const std::string* value) {
  if (!value) return false;
  std::string v = *value;
  std::transform(v.begin(), v.end(), v.begin(), [](unsigned char c) { return std::tolower(c); });
  return v == "true" || v == "1";
}

// zlib- or gzip-wrapped deflate data, inflated up to `expected` bytes.
std::string inflate_bytes(const std::string& in, size_t expected, const std::string& path) {
  std::string out(expected, '\0');
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw std::runtime_error("zlib initialisation failed");
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(expected);
  const int ret = inflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  inflateEnd(&zs);
  if (ret != Z_STREAM_END && ret != Z_BUF_ERROR && ret != Z_OK)
    throw InputError(path, "CompressedData", "corrupt zlib data (" + std::string(zs.msg ? zs.msg : "error") + ")");
  return out;
}

// MetaImage ElementType names.
const std::map<std::string, Scalar>& meta_types() {
  static const std::map<std::string, Scalar> types = {
      {"MET_UCHAR", Scalar::kU8},  {"MET_CHAR", Scalar::kI8},  {"MET_USHORT", Scalar::kU16},
      {"MET_SHORT", Scalar::kI16}, {"MET_UINT", Scalar::kU32}, {"MET_INT", Scalar::kI32},
      {"MET_FLOAT", Scalar::kF32}, {"MET_DOUBLE", Scalar::kF64}};
  return types;
}

// Reads the geometry of a MetaImage header (no data).
RawVolume meta_geometry(const MetaHeader& h, const std::string& path) {
  RawVolume v;
  v.dim_key = "NDims";
  v.channel_key = "ElementNumberOfChannels";
  if (const std::string* t = find_key(h, {"ObjectType"}); t && *t != "Image")
    throw InputError(path, "ObjectType", "expected Image, found '" + *t + "'");
  const std::string* nd = find_key(h, {"NDims"});
  if (!nd) throw InputError(path, "NDims", "missing required key");
  const double ndims = meta_numbers(*nd, path, "NDims", 1)[0];
  if (ndims != 2 && ndims != 3)
    throw InputError(path, "NDims", "unsupported dimension " + *nd + " (expected 2 or 3)");
  v.ndims = int(ndims);
  const std::string* ds = find_key(h, {"DimSize"});
  if (!ds) throw InputError(path, "DimSize", "missing required key");
  const auto sizes = meta_numbers(*ds, path, "DimSize", v.ndims);
  for (int a = 0; a < v.ndims; ++a) {
    if (sizes[a] < 1 || sizes[a] != std::floor(sizes[a]) || sizes[a] > 1e9)
      throw InputError(path, "DimSize", "expected positive integers, found '" + *ds + "'");
    v.size[a] = int64_t(sizes[a]);
  }
  if (const std::string* s = find_key(h, {"ElementSpacing", "ElementSize"})) {
    v.spacing_key = h.keys.count("ElementSpacing") ? "ElementSpacing" : "ElementSize";
    const auto sp = meta_numbers(*s, path, v.spacing_key, v.ndims);
    std::copy(sp.begin(), sp.end(), v.spacing.begin());
  }
  for (const char* key : {"Offset", "Origin", "Position"}) {
    if (const std::string* o = find_key(h, {key})) {
      const auto org = meta_numbers(*o, path, key, v.ndims);
      std::copy(org.begin(), org.end(), v.origin.begin());
      break;
    }
  }
  if (const std::string* c = find_key(h, {"ElementNumberOfChannels"})) {
    const double ch = meta_numbers(*c, path, "ElementNumberOfChannels", 1)[0];
    if (ch < 1 || ch > 3 || ch != std::floor(ch))
      throw InputError(path, "ElementNumberOfChannels", "unsupported number of channels " + *c);
    v.channels = int(ch);
  }
  // TransformMatrix is accepted and ignored: the framework's grids are axis-aligned.
  return v;
}

// Reads a .mha or .mhd file completely.
RawVolume read_meta(const std::string& path) {
  const std::string bytes = read_bytes(path);
  const MetaHeader h = parse_meta_header(bytes, path);
  RawVolume v = meta_geometry(h, path);
  const std::string* et = find_key(h, {"ElementType"});
  if (!et) throw InputError(path, "ElementType", "missing required key");
  auto type_it = meta_types().find(*et);
  if (type_it == meta_types().end()) throw InputError(path, "ElementType", "unsupported element type " + *et);
  const Scalar type = type_it->second;
  const bool msb = meta_true(find_key(h, {"BinaryDataByteOrderMSB", "ElementByteOrderMSB"}));
  const bool swap = msb != (std::endian::native == std::endian::big);
  const bool compressed = meta_true(find_key(h, {"CompressedData"}));
  const int64_t count = v.num_voxels() * v.channels;
  const size_t expected = size_t(count) * scalar_bytes(type);

  // The data: after the header (LOCAL) or in a file beside the header.
  const std::string& df = h.keys.at("ElementDataFile");
  std::string data_path = path, data;
  if (df == "LOCAL") {
    data = bytes.substr(h.data_start);
  } else {
    if (df.rfind("LIST", 0) == 0 || df.find('%') != std::string::npos)
      throw InputError(path, "ElementDataFile", "file lists and patterns are not supported");
    data_path = (fs::path(path).parent_path() / df).string();
    if (!fs::is_regular_file(data_path))
      throw InputError(data_path, "", "data file not found (named by ElementDataFile in " + path + ")");
    data = read_bytes(data_path);
    if (const std::string* hs = find_key(h, {"HeaderSize"})) {
      const double skip = meta_numbers(*hs, path, "HeaderSize", 1)[0];
      if (skip == -1 && !compressed && data.size() >= expected) data = data.substr(data.size() - expected);
      else if (skip > 0) data = skip < double(data.size()) ? data.substr(size_t(skip)) : std::string();
    }
  }
  if (compressed) {
    if (const std::string* cs = find_key(h, {"CompressedDataSize"})) {
      const double n = meta_numbers(*cs, path, "CompressedDataSize", 1)[0];
      if (n >= 0 && n < double(data.size())) data.resize(size_t(n));
    }
    data = inflate_bytes(data, expected, data_path);
  }
  if (data.size() < expected)
    throw InputError(data_path, "ElementDataFile", "data holds " + std::to_string(data.size()) + " bytes, expected " +
                                                       std::to_string(expected));
  v.values = decode(data.data(), count, type, swap);
  return v;
}

// Writes a MetaImage: .mha with LOCAL data, or .mhd plus a .raw/.zraw data file beside it.
void write_meta(const RawVolume& v, const std::string& path, bool compress) {
  std::string data = float_bytes(v.values);
  if (compress) {
    uLongf n = compressBound(data.size());
    std::string z(n, '\0');
    if (compress2(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(data.data()), data.size(),
                  Z_DEFAULT_COMPRESSION) != Z_OK)
      throw std::runtime_error(path + ": zlib compression failed");
    z.resize(n);
    data = std::move(z);
  }
  auto list = [&](const std::array<double, 3>& a) {
    std::string s;
    for (int i = 0; i < v.ndims; ++i) s += (i ? " " : "") + exact(a[i]);
    return s;
  };
  std::string h = "ObjectType = Image\nNDims = " + std::to_string(v.ndims) + "\n";
  h += "BinaryData = True\nBinaryDataByteOrderMSB = False\n";
  h += std::string("CompressedData = ") + (compress ? "True\nCompressedDataSize = " + std::to_string(data.size()) : "False") + "\n";
  h += v.ndims == 2 ? "TransformMatrix = 1 0 0 1\n" : "TransformMatrix = 1 0 0 0 1 0 0 0 1\n";
  h += "Offset = " + list(v.origin) + "\nElementSpacing = " + list(v.spacing) + "\nDimSize =";
  for (int i = 0; i < v.ndims; ++i) h += " " + std::to_string(v.size[i]);
  h += "\n";
  if (v.channels > 1) h += "ElementNumberOfChannels = " + std::to_string(v.channels) + "\n";
  h += "ElementType = MET_FLOAT\n";
  if (extension_of(path) == ".mha") {
    write_file_atomically(path, h + "ElementDataFile = LOCAL\n" + data);
    return;
  }
  const fs::path p(path);
  const std::string data_name = p.stem().string() + (compress ? ".zraw" : ".raw");
  write_file_atomically((p.parent_path() / data_name).string(), data);
  write_file_atomically(path, h + "ElementDataFile = " + data_name + "\n");
}

// Geometry of a .mha/.mhd from its header only.
int meta_dimension(const std::string& path) {
  std::string head = read_bytes(path, 1 << 16);
  const size_t pos = head.find("ElementDataFile");
  if (pos != std::string::npos) head.resize(std::min(head.size(), head.find('\n', pos)));
  head += "\n";
  return meta_geometry(parse_meta_header(head, path), path).effective_dimension();
}

// ---------------------------------------------------------------- NIfTI-1

constexpr size_t kNiftiHeaderBytes = 348;
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
  if (nifti_field<int16_t>(bytes, 252, swap) > 0) {
    for (int a = 0; a < 3; ++a) v.origin[a] = nifti_field<float>(bytes, 268 + 4 * a, swap);
  } else if (nifti_field<int16_t>(bytes, 254, swap) > 0) {
    for (int a = 0; a < 3; ++a) v.origin[a] = nifti_field<float>(bytes, 280 + 16 * a + 12, swap);
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

// ---------------------------------------------------------------- OpenCV (2D)

// A 2D grey image through OpenCV; colour is converted to grey, 8/16-bit and float kept.
RawVolume read_opencv(const std::string& path) {
  require_exists(path);
  const cv::Mat m = cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw InputError(path, "", "cannot decode the image");
  cv::Mat d;
  m.convertTo(d, CV_64F);
  RawVolume v;
  v.ndims = 2;
  v.size = {d.cols, d.rows, 1};
  v.values.resize(size_t(d.cols) * d.rows);
  for (int y = 0; y < d.rows; ++y)
    for (int x = 0; x < d.cols; ++x) v.values[size_t(y) * d.cols + x] = d.at<double>(y, x);
  return v;
}

// Writes 8-bit grey after clamping to [0, 255] (spacing and origin are lost).
void write_opencv(const RawVolume& v, const std::string& path) {
  cv::Mat m(int(v.size[1]), int(v.size[0]), CV_8U);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x)
      m.at<uint8_t>(y, x) = uint8_t(std::lround(std::clamp(v.values[size_t(y) * m.cols + x], 0.0, 255.0)));
  write_via_temporary(path, [&](const std::string& tmp) {
    if (!cv::imwrite(tmp, m)) throw std::runtime_error(path + ": cannot write image");
  });
}

// ---------------------------------------------------------------- dispatch and checks

// Decodes any supported file by its extension.
RawVolume read_volume(const std::string& path) {
  const std::string ext = extension_of(path);
  if (ext == ".mha" || ext == ".mhd") return read_meta(path);
  if (ext == ".nii" || ext == ".nii.gz") return decode_nifti(read_gz_bytes(path), path, false);
  if (is_opencv_extension(ext)) return read_opencv(path);
  unknown_format(path);
}

// Writes any supported format by its extension.
void write_volume(const RawVolume& v, const std::string& path, const ImageWriteOptions& options) {
  const std::string ext = extension_of(path);
  if (ext == ".mha" || ext == ".mhd") return write_meta(v, path, options.compress);
  if (ext == ".nii" || ext == ".nii.gz") return write_nifti(v, path);
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
  }
  for (size_t i = 0; i < v.values.size(); ++i) {
    if (std::isfinite(v.values[i])) continue;
    const GridIndex<D> idx = g.index(int64_t(i) / channels);
    std::string where = "voxel (";
    for (int a = 0; a < D; ++a) where += (a ? ", " : "") + std::to_string(idx[a]);
    throw InputError(path, where + ")", std::isnan(v.values[i]) ? "value is NaN" : "value is infinite");
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
  }
  return v;
}

}  // namespace

// Reads only the header (MetaImage, NIfTI); OpenCV formats are 2D.
int image_file_dimension(const std::string& path) {
  const std::string ext = extension_of(path);
  if (ext == ".mha" || ext == ".mhd") return meta_dimension(path);
  if (ext == ".nii" || ext == ".nii.gz") return decode_nifti(read_gz_bytes(path, kNiftiHeaderBytes), path, true).effective_dimension();
  if (is_opencv_extension(ext)) return 2;
  unknown_format(path);
}

// Decodes, checks (dimension, one channel, spacing, finite voxels) and converts to float.
template <int D>
Image<D> read_image(const std::string& path) {
  const RawVolume v = read_volume(path);
  Image<D> image(checked_grid<D>(v, path, 1));
  for (size_t i = 0; i < v.values.size(); ++i) image[int64_t(i)] = static_cast<float>(v.values[i]);
  return image;
}

// Stores the grid and the voxels through the shared RawVolume writer.
template <int D>
void write_image(const Image<D>& image, const std::string& path, const ImageWriteOptions& options) {
  RawVolume v = raw_of<D>(image.grid(), 1);
  v.values.assign(image.data().begin(), image.data().end());
  write_volume(v, path, options);
}

// Default options: uncompressed.
template <int D>
void write_image(const Image<D>& image, const std::string& path) {
  write_image<D>(image, path, ImageWriteOptions{});
}

// Vector fields go to MetaImage (channels) or NIfTI (intent vector) only.
template <int D>
void write_vector_field(const VectorField<D>& field, const std::string& path) {
  RawVolume v = raw_of<D>(field.grid(), D);
  v.values.resize(size_t(field.num_voxels()) * D);
  for (int64_t i = 0; i < field.num_voxels(); ++i)
    for (int a = 0; a < D; ++a) v.values[size_t(i) * D + a] = field[i][a];
  const std::string ext = extension_of(path);
  if (is_opencv_extension(ext)) throw InputError(path, "", "vector fields need .mha, .mhd, .nii or .nii.gz");
  write_volume(v, path, ImageWriteOptions{});
}

// As read_image, with D interleaved components per voxel.
template <int D>
VectorField<D> read_vector_field(const std::string& path) {
  const RawVolume v = read_volume(path);
  VectorField<D> field(checked_grid<D>(v, path, D));
  for (int64_t i = 0; i < field.num_voxels(); ++i)
    for (int a = 0; a < D; ++a) field[i][a] = v.values[size_t(i) * D + a];
  return field;
}

template Image<2> read_image<2>(const std::string&);
template Image<3> read_image<3>(const std::string&);
template void write_image<2>(const Image<2>&, const std::string&);
template void write_image<3>(const Image<3>&, const std::string&);
template void write_image<2>(const Image<2>&, const std::string&, const ImageWriteOptions&);
template void write_image<3>(const Image<3>&, const std::string&, const ImageWriteOptions&);
template void write_vector_field<2>(const VectorField<2>&, const std::string&);
template void write_vector_field<3>(const VectorField<3>&, const std::string&);
template VectorField<2> read_vector_field<2>(const std::string&);
template VectorField<3> read_vector_field<3>(const std::string&);

}  // namespace dsnake
