// INRIMAGE-4 (.inr, .inr.gz) reading and writing; see image_io.h. The header is a multiple of
// 256 bytes, from "#INRIMAGE-4#{" to "##}\n", of KEY=value lines (XDIM YDIM ZDIM VDIM TYPE
// PIXSIZE CPU VX VY VZ, optional XO YO ZO); the voxels follow, x fastest, VDIM components
// interleaved. The format names no orientation: the axes are the world's, and the origin
// XO YO ZO is taken as LPS world coordinates as it stands.
#include "framework/io/image_io_detail.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <bit>
#include <filesystem>
#include <cerrno>
#include <cmath>
#include <sstream>

namespace dsnake::detail {

namespace {

constexpr char kInrMagic[] = "#INRIMAGE-4#{";
constexpr char kInrEnd[] = "##}\n";
constexpr size_t kInrBlock = 256;

struct InrHeader {
  std::map<std::string, std::string> keys;
  size_t data_start = 0;  // byte past "##}\n"
};

// s without leading and trailing blanks.
std::string inr_strip(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  const size_t b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// The KEY=value lines between the magic and the end mark; comments (#...) and the newline
// padding are skipped.
InrHeader parse_inr_header(const std::string& bytes, const std::string& path) {
  if (bytes.compare(0, sizeof(kInrMagic) - 1, kInrMagic) != 0)
    throw InputError(path, "magic", "not an INRIMAGE-4 file (expected '#INRIMAGE-4#{' at the start)");
  const size_t end = bytes.find(kInrEnd);
  if (end == std::string::npos) throw InputError(path, "header", "unterminated header (no '##}' line)");
  InrHeader h;
  h.data_start = end + sizeof(kInrEnd) - 1;
  std::istringstream in(bytes.substr(sizeof(kInrMagic) - 1, end - (sizeof(kInrMagic) - 1)));
  for (std::string line; std::getline(in, line);) {
    line = inr_strip(line);
    if (line.empty() || line[0] == '#') continue;
    const size_t eq = line.find('=');
    if (eq == std::string::npos) throw InputError(path, "header", "unreadable line '" + line + "' (expected KEY=value)");
    h.keys[inr_strip(line.substr(0, eq))] = inr_strip(line.substr(eq + 1));
  }
  return h;
}

// A whole number in [lo, hi] under `key`, or `fallback` when the key is absent.
int64_t inr_integer(const InrHeader& h, const std::string& key, const std::string& path, int64_t lo, int64_t hi,
                    int64_t fallback) {
  auto it = h.keys.find(key);
  if (it == h.keys.end()) {
    if (fallback < 0) throw InputError(path, key, "missing required key");
    return fallback;
  }
  char* end = nullptr;
  errno = 0;
  const long long n = std::strtoll(it->second.c_str(), &end, 10);
  if (end == it->second.c_str() || *end != '\0' || errno == ERANGE || n < lo || n > hi)
    throw InputError(path, key, "expected a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                                    "], found '" + it->second + "'");
  return n;
}

// A number under `key`, or `fallback` when the key is absent.
double inr_number(const InrHeader& h, const std::string& key, const std::string& path, double fallback) {
  auto it = h.keys.find(key);
  if (it == h.keys.end()) return fallback;
  char* end = nullptr;
  const double d = std::strtod(it->second.c_str(), &end);
  if (end == it->second.c_str() || *end != '\0' || !std::isfinite(d))
    throw InputError(path, key, "expected a number, found '" + it->second + "'");
  return d;
}

// The voxel type from TYPE and PIXSIZE.
Scalar inr_type(const InrHeader& h, const std::string& path) {
  auto type = h.keys.find("TYPE");
  if (type == h.keys.end()) throw InputError(path, "TYPE", "missing required key");
  auto pix = h.keys.find("PIXSIZE");
  if (pix == h.keys.end()) throw InputError(path, "PIXSIZE", "missing required key");
  const std::string& t = type->second;
  const std::string& p = pix->second;
  const int bits = p == "8 bits" ? 8 : p == "16 bits" ? 16 : p == "32 bits" ? 32 : p == "64 bits" ? 64 : 0;
  if (bits == 0) throw InputError(path, "PIXSIZE", "unsupported PIXSIZE '" + p + "' (expected 8, 16, 32 or 64 bits)");
  if (t == "unsigned fixed" && bits <= 32) return bits == 8 ? Scalar::kU8 : bits == 16 ? Scalar::kU16 : Scalar::kU32;
  if (t == "signed fixed" && bits <= 32) return bits == 8 ? Scalar::kI8 : bits == 16 ? Scalar::kI16 : Scalar::kI32;
  if (t == "float" && bits >= 32) return bits == 32 ? Scalar::kF32 : Scalar::kF64;
  throw InputError(path, "TYPE", "unsupported TYPE '" + t + "' with PIXSIZE '" + p +
                                     "' (expected unsigned/signed fixed of 8-32 bits, or float of 32/64 bits)");
}

// True if CPU names a big-endian machine (sun, sgi); little endian (decm, alpha, pc) is the
// default.
bool inr_big_endian(const InrHeader& h, const std::string& path) {
  auto it = h.keys.find("CPU");
  if (it == h.keys.end()) return false;
  const std::string& c = it->second;
  if (c == "decm" || c == "alpha" || c == "pc") return false;
  if (c == "sun" || c == "sgi") return true;
  throw InputError(path, "CPU", "unknown CPU '" + c + "' (expected decm, alpha, pc, sun or sgi)");
}

// The geometry of an INRIMAGE header (a volume with ZDIM = 1 counts as 2D).
RawVolume inr_geometry(const InrHeader& h, const std::string& path) {
  RawVolume v;
  v.dim_key = "ZDIM";
  v.spacing_key = "VX/VY/VZ";
  v.channel_key = "VDIM";
  const char* dims[3] = {"XDIM", "YDIM", "ZDIM"};
  const char* steps[3] = {"VX", "VY", "VZ"};
  const char* origins[3] = {"XO", "YO", "ZO"};
  v.ndims = 3;
  for (int a = 0; a < 3; ++a) {
    v.size[a] = inr_integer(h, dims[a], path, 1, 2147483647, a == 2 ? 1 : -1);
    v.spacing[a] = inr_number(h, steps[a], path, 1.0);
    v.origin[a] = inr_number(h, origins[a], path, 0.0);
  }
  v.channels = int(inr_integer(h, "VDIM", path, 1, 3, 1));
  return v;
}

}  // namespace

// Reads a .inr or .inr.gz file completely (gunzipped by read_gz_bytes); the data length is
// checked against XDIM x YDIM x ZDIM x VDIM x PIXSIZE before any voxel is decoded.
RawVolume read_inr(const std::string& path) {
  // The header first, then no more bytes than it declares (a gzip bomb is not inflated).
  const std::string head = read_gz_bytes(path, 1 << 16);
  const InrHeader hh = parse_inr_header(head, path);
  const RawVolume g = inr_geometry(hh, path);
  const double values = double(g.size[0]) * double(g.size[1]) * double(g.size[2]) * g.channels;
  check_declared_values(values, path, "XDIM/YDIM/ZDIM");
  const double declared = double(hh.data_start) + values * scalar_bytes(inr_type(hh, path));
  std::error_code ec;
  const double stored = double(std::filesystem::file_size(path, ec));
  if (extension_of(path) == ".inr.gz" && !ec) check_inflatable(declared, stored, path, "XDIM/YDIM/ZDIM");
  const std::string bytes = read_gz_bytes(path, size_t(declared), size_t(declared));  // one buffer of that size
  const InrHeader h = parse_inr_header(bytes, path);
  RawVolume v = inr_geometry(h, path);
  const Scalar type = inr_type(h, path);
  const bool swap = inr_big_endian(h, path) != (std::endian::native == std::endian::big);
  const double count = double(v.size[0]) * double(v.size[1]) * double(v.size[2]) * v.channels;
  const double expected = count * scalar_bytes(type);
  const double held = double(bytes.size() - h.data_start);
  if (held < expected)
    throw InputError(path, "XDIM/YDIM/ZDIM", "XDIM x YDIM x ZDIM x VDIM x PIXSIZE need " + exact(expected) +
                                                 " bytes of data, the file holds " + exact(held) +
                                                 " (truncated data or wrong sizes)");
  v.values = decode<float>(bytes.data() + h.data_start, int64_t(count), type, swap);
  return v;
}

// The number of dimensions of an INRIMAGE from its header (ZDIM = 1: 2D).
int inr_dimension(const std::string& path) {
  const std::string head = read_gz_bytes(path, 1 << 16);
  return inr_geometry(parse_inr_header(head, path), path).effective_dimension();
}

// Writes float32 little-endian INRIMAGE-4 (a 2D image with ZDIM=1), header padded to 256
// bytes; gzipped for .inr.gz. The format holds no direction: the axes must be the world's.
void write_inr(const RawVolume& v, const std::string& path) {
  for (int a = 0; a < v.ndims; ++a)
    for (int k = 0; k < v.ndims; ++k)
      if (std::abs(v.axes[a][k] - (a == k ? 1.0 : 0.0)) > 1e-9)
        throw InputError(path, "", "INRIMAGE holds no direction; this image's axes are rotated (write .nrrd or .mha)");
  std::string h = kInrMagic;
  h += "\nXDIM=" + std::to_string(v.size[0]) + "\nYDIM=" + std::to_string(v.size[1]) +
       "\nZDIM=" + std::to_string(v.ndims == 3 ? v.size[2] : 1) + "\nVDIM=" + std::to_string(v.channels) +
       "\nTYPE=float\nPIXSIZE=32 bits\nCPU=decm\nVX=" + exact(v.spacing[0]) + "\nVY=" + exact(v.spacing[1]) +
       "\nVZ=" + exact(v.ndims == 3 ? v.spacing[2] : 1.0) + "\nXO=" + exact(v.origin[0]) + "\nYO=" +
       exact(v.origin[1]) + "\nZO=" + exact(v.ndims == 3 ? v.origin[2] : 0.0) + "\n";
  const size_t total = (h.size() + sizeof(kInrEnd) - 1 + kInrBlock - 1) / kInrBlock * kInrBlock;
  h += std::string(total - h.size() - (sizeof(kInrEnd) - 1), '\n') + kInrEnd;
  std::string converted;
  const std::vector<std::string_view> parts{h, stored_view(v.data(), false, converted)};
  if (extension_of(path) == ".inr.gz") write_stream_atomically(path, [&](const auto& put) { gzip_into(parts, path, put); });
  else write_file_atomically(path, parts);
}

}  // namespace dsnake::detail
