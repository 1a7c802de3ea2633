// MetaImage (.mha/.mhd) reading and writing; see image_io.h.
#include "framework/io/image_io_detail.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>

namespace dsnake::detail {

namespace fs = std::filesystem;


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

// MetaImage ElementType names. MetaIO stores MET_LONG and MET_ULONG in 4 bytes on every
// platform (metaTypes.h's MET_ValueTypeSize), whatever the writer's `long`.
const std::map<std::string, Scalar>& meta_types() {
  static const std::map<std::string, Scalar> types = {
      {"MET_UCHAR", Scalar::kU8},  {"MET_CHAR", Scalar::kI8},  {"MET_USHORT", Scalar::kU16},
      {"MET_SHORT", Scalar::kI16}, {"MET_UINT", Scalar::kU32}, {"MET_INT", Scalar::kI32},
      {"MET_LONG", Scalar::kI32},  {"MET_ULONG", Scalar::kU32},
      {"MET_LONG_LONG", Scalar::kI64}, {"MET_ULONG_LONG", Scalar::kU64},
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
  // TransformMatrix: ITK's MetaIO convention, value [a * n + k] is world component k of index
  // axis a (read_volume aligns the axes with the world's: image_io_detail.h).
  if (const std::string* t = find_key(h, {"TransformMatrix", "Rotation", "Orientation"})) {
    const auto m = meta_numbers(*t, path, "TransformMatrix", -1);
    if (int(m.size()) == v.ndims * v.ndims) {
      for (int a = 0; a < v.ndims; ++a)
        for (int k = 0; k < v.ndims; ++k) v.axes[a][k] = m[a * v.ndims + k];
    } else {
      std::fprintf(stderr, "dsnake: warning: %s: TransformMatrix holds %zu numbers, not %d; ignored\n", path.c_str(),
                   m.size(), v.ndims * v.ndims);
    }
  }
  return v;
}

// Reads a .mha or .mhd file completely.
RawVolume read_meta(const std::string& path) {
  // (The header ends with its ElementDataFile line: ended if that line's end was read.)
  const MetaHeader h = parse_header_of(
      path, [&](const std::string& bytes) { return parse_meta_header(bytes, path); },
      [](const MetaHeader& m, const std::string& bytes) { return m.data_start < bytes.size(); });
  RawVolume v = meta_geometry(h, path);
  const std::string* et = find_key(h, {"ElementType"});
  if (!et) throw InputError(path, "ElementType", "missing required key");
  auto type_it = meta_types().find(*et);
  if (type_it == meta_types().end()) throw InputError(path, "ElementType", "unsupported element type " + *et);
  const Scalar type = type_it->second;
  const bool msb = meta_true(find_key(h, {"BinaryDataByteOrderMSB", "ElementByteOrderMSB"}));
  const bool swap = msb != (std::endian::native == std::endian::big);
  const bool compressed = meta_true(find_key(h, {"CompressedData"}));
  // The product in double: three sizes of up to 1e9 overflow int64 (2^21 x 2^21 x 2^22 wraps to
  // 0 voxels), and the limit keeps the count that passes well inside it.
  check_declared_values(double(v.size[0]) * double(v.size[1]) * double(v.size[2]) * v.channels, path, "DimSize");
  const int64_t count = v.num_voxels() * v.channels;
  const size_t expected = size_t(count) * scalar_bytes(type);

  // The data: after the header (LOCAL) or in a file beside the header, from byte `offset` of
  // `data_path`, which holds `length` bytes from there. Raw data is read from the file straight
  // into the values, compressed data decoded as it is inflated (the stored or inflated
  // bytes are never held whole).
  const std::string& df = h.keys.at("ElementDataFile");
  std::string data_path = path;
  uint64_t offset = 0, length = 0;
  std::error_code ec;
  if (df == "LOCAL") {
    offset = h.data_start;
    const uintmax_t size = fs::file_size(path, ec);
    length = ec || size < offset ? 0 : size - offset;
  } else {
    if (df.rfind("LIST", 0) == 0 || df.find('%') != std::string::npos)
      throw InputError(path, "ElementDataFile", "file lists and patterns are not supported");
    data_path = (fs::path(path).parent_path() / df).string();
    // (A name too long for the system is "not found", not a filesystem_error: found by fuzzing.)
    if (!fs::is_regular_file(data_path, ec))
      throw InputError(data_path, "", "data file not found (named by ElementDataFile in " + path + ")");
    const uintmax_t size = fs::file_size(data_path, ec);
    length = ec ? 0 : size;
    if (const std::string* hs = find_key(h, {"HeaderSize"})) {
      const double skip = meta_numbers(*hs, path, "HeaderSize", 1)[0];
      if (skip == -1 && !compressed && length >= expected) offset = length - expected;
      else if (skip > 0) offset = skip < double(length) ? uint64_t(skip) : length;
      length -= offset;
    }
  }
  size_t found = std::min<uint64_t>(length, expected);
  if (compressed) {
    if (const std::string* cs = find_key(h, {"CompressedDataSize"})) {
      const double n = meta_numbers(*cs, path, "CompressedDataSize", 1)[0];
      if (n >= 0 && n < double(length)) length = uint64_t(n);
    }
    check_inflatable(double(expected), double(length), data_path, "CompressedData");
    found = inflate_file_values(data_path, offset, length, 0, count, type, swap, v.values, "CompressedData", "zlib");
  }
  if (found < expected)
    throw InputError(data_path, "ElementDataFile", "data holds " + std::to_string(found) + " bytes, expected " +
                                                       std::to_string(expected));
  if (!compressed) read_stored_values(data_path, offset, count, type, swap, v.values);
  return v;
}

// Writes a MetaImage (LPS world, as MetaImage's own convention): .mha with LOCAL data, or .mhd
// plus a .raw/.zraw data file beside it.
void write_meta(const RawVolume& v, const std::string& path, bool compress) {
  const bool local = extension_of(path) == ".mha";
  std::string converted, z;
  std::string_view data = stored_view(v.data(), v.label, converted);  // the values, or their zlib stream
  if (compress) {
    uLongf n = compressBound(data.size());
    z.assign(n, '\0');
    if (compress2(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(data.data()), data.size(),
                  Z_DEFAULT_COMPRESSION) != Z_OK)
      throw std::runtime_error(path + ": zlib compression failed");
    z.resize(n);
    data = z;
  }
  auto list = [&](const std::array<double, 3>& a) {
    std::string s;
    for (int i = 0; i < v.ndims; ++i) s += (i ? " " : "") + exact(a[i]);
    return s;
  };
  std::string h = "ObjectType = Image\nNDims = " + std::to_string(v.ndims) + "\n";
  h += "BinaryData = True\nBinaryDataByteOrderMSB = False\n";
  h += std::string("CompressedData = ") + (compress ? "True\nCompressedDataSize = " + std::to_string(data.size()) : "False") + "\n";
  h += "TransformMatrix =";  // ITK's MetaIO order: index axis a's world direction, a = 0, 1(, 2)
  for (int a = 0; a < v.ndims; ++a)
    for (int k = 0; k < v.ndims; ++k) h += " " + exact(v.axes[a][k]);
  h += "\n";
  h += "Offset = " + list(v.origin) + "\nElementSpacing = " + list(v.spacing) + "\nDimSize =";
  for (int i = 0; i < v.ndims; ++i) h += " " + std::to_string(v.size[i]);
  h += "\n";
  if (v.channels > 1) h += "ElementNumberOfChannels = " + std::to_string(v.channels) + "\n";
  h += v.label ? "ElementType = MET_UCHAR\n" : "ElementType = MET_FLOAT\n";
  if (local) {
    write_file_atomically(path, {h + "ElementDataFile = LOCAL\n", data});
    return;
  }
  const fs::path p(path);
  const std::string data_name = p.stem().string() + (compress ? ".zraw" : ".raw");
  write_file_atomically((p.parent_path() / data_name).string(), {data});
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

}  // namespace dsnake::detail
