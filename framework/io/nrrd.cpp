// NRRD (.nrrd with attached data, .nhdr with a detached data file) reading and writing; see
// image_io.h. Read: encodings raw and gzip, either byte order, the 8- to 32-bit integer types,
// float and double, 2 or 3 spatial axes plus an optional leading vector axis, and the geometry
// from `space directions`/`space origin` (or the older `spacings`/`axis mins`). Worlds are
// converted to LPS (image_io_detail.h): `right-anterior-superior` negates x and y,
// `left-anterior-superior` negates y; `3D-right-handed` and a bare `space dimension` are read
// as LPS (they name no patient axes, and the framework does not flip what it cannot name).
// Every number of the header is checked against the data before anything is allocated.
#include "framework/io/image_io_detail.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <zlib.h>

#include <bit>
#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake::detail {

namespace {

namespace fs = std::filesystem;

// Each size at most this (Grid<D> holds int sizes), and a whole data block at most 2^62 bytes.
constexpr int64_t kMaxAxisSize = 2147483647;
constexpr double kMaxDataBytes = 4.6e18;

// s without leading and trailing blanks.
std::string strip(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  const size_t b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// s in lower case (NRRD field names and values are matched case-insensitively).
std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Blank-separated words of a field's value.
std::vector<std::string> words_of(const std::string& value) {
  std::istringstream in(value);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

struct NrrdHeader {
  std::map<std::string, std::string> fields;  // lower-case field name -> value
  size_t data_start = std::string::npos;      // byte past the blank line that ends the header
};

// The magic line, then "field: value" lines up to a blank line (attached data follows it) or
// the end of the bytes (a detached header). Comments (#) and "key:=value" pairs are skipped.
NrrdHeader parse_nrrd_header(const std::string& bytes, const std::string& path) {
  if (bytes.size() < 8 || bytes.compare(0, 7, "NRRD000") != 0 || bytes[7] < '1' || bytes[7] > '5')
    throw InputError(path, "magic", "not a NRRD file (the first line must be NRRD0001 .. NRRD0005)");
  NrrdHeader h;
  size_t pos = bytes.find('\n');
  int line_no = 1;
  while (pos != std::string::npos && pos + 1 < bytes.size()) {
    const size_t start = pos + 1;
    pos = bytes.find('\n', start);
    const std::string line = strip(bytes.substr(start, (pos == std::string::npos ? bytes.size() : pos) - start));
    ++line_no;
    if (line.empty()) {
      h.data_start = pos == std::string::npos ? bytes.size() : pos + 1;
      return h;
    }
    if (line[0] == '#' || line.find(":=") != std::string::npos) continue;
    const size_t colon = line.find(": ");
    if (colon == std::string::npos || line.size() > 65536)
      throw InputError(path, "header line " + std::to_string(line_no), "unreadable header: expected 'field: value'");
    h.fields[lower(strip(line.substr(0, colon)))] = strip(line.substr(colon + 2));
  }
  return h;
}

// The value of field `name` ("datafile" and "data file" are one field), or null.
const std::string* nrrd_field(const NrrdHeader& h, const std::string& name) {
  auto it = h.fields.find(name);
  if (it == h.fields.end() && name.find(' ') != std::string::npos) {
    std::string joined = name;
    joined.erase(std::remove(joined.begin(), joined.end(), ' '), joined.end());
    it = h.fields.find(joined);
  }
  return it == h.fields.end() ? nullptr : &it->second;
}

// The value of a field the file must have.
const std::string& required_field(const NrrdHeader& h, const std::string& name, const std::string& path) {
  const std::string* v = nrrd_field(h, name);
  if (!v) throw InputError(path, name, "missing required field");
  return *v;
}

// A whole number in [lo, hi] from one word of a field.
int64_t nrrd_integer(const std::string& word, const std::string& path, const std::string& field, int64_t lo,
                     int64_t hi) {
  char* end = nullptr;
  errno = 0;
  const long long n = std::strtoll(word.c_str(), &end, 10);
  if (end == word.c_str() || *end != '\0' || errno == ERANGE || n < lo || n > hi)
    throw InputError(path, field, "expected a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                                      "], found '" + word + "'");
  return n;
}

// A number from one word of a field ("nan" allowed where the caller allows it).
double nrrd_number(const std::string& word, const std::string& path, const std::string& field) {
  char* end = nullptr;
  const double d = std::strtod(word.c_str(), &end);
  if (end == word.c_str() || *end != '\0') throw InputError(path, field, "expected a number, found '" + word + "'");
  return d;
}

// A "(x,y[,z])" vector of n numbers, as in `space directions` and `space origin`.
std::vector<double> nrrd_vector(const std::string& token, const std::string& path, const std::string& field, int n) {
  if (token.size() < 2 || token.front() != '(' || token.back() != ')')
    throw InputError(path, field, "expected a vector '(x,y,z)', found '" + token + "'");
  std::vector<double> out;
  std::stringstream in(token.substr(1, token.size() - 2));
  for (std::string part; std::getline(in, part, ',');) out.push_back(nrrd_number(strip(part), path, field));
  if (int(out.size()) != n)
    throw InputError(path, field, "expected " + std::to_string(n) + " components, found '" + token + "'");
  return out;
}

// A field's value as vectors; "(1, 0)" with blanks inside is one vector.
std::vector<std::string> vector_tokens(const std::string& value) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  for (char c : value) {
    if (c == '(') ++depth;
    if (c == ')') --depth;
    if ((c == ' ' || c == '\t') && depth == 0) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (c != ' ' && c != '\t') {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

// NRRD's type names (the NRRD file format specification's list); "block" is refused.
Scalar nrrd_type(const std::string& value, const std::string& path) {
  static const std::map<std::string, Scalar> types = {
      {"signed char", Scalar::kI8},         {"int8", Scalar::kI8},           {"int8_t", Scalar::kI8},
      {"uchar", Scalar::kU8},               {"unsigned char", Scalar::kU8},  {"uint8", Scalar::kU8},
      {"uint8_t", Scalar::kU8},             {"short", Scalar::kI16},         {"short int", Scalar::kI16},
      {"signed short", Scalar::kI16},       {"signed short int", Scalar::kI16}, {"int16", Scalar::kI16},
      {"int16_t", Scalar::kI16},            {"ushort", Scalar::kU16},        {"unsigned short", Scalar::kU16},
      {"unsigned short int", Scalar::kU16}, {"uint16", Scalar::kU16},        {"uint16_t", Scalar::kU16},
      {"int", Scalar::kI32},                {"signed int", Scalar::kI32},    {"int32", Scalar::kI32},
      {"int32_t", Scalar::kI32},            {"uint", Scalar::kU32},          {"unsigned int", Scalar::kU32},
      {"uint32", Scalar::kU32},             {"uint32_t", Scalar::kU32},      {"longlong", Scalar::kI64},
      {"long long", Scalar::kI64},          {"long long int", Scalar::kI64}, {"signed long long", Scalar::kI64},
      {"signed long long int", Scalar::kI64}, {"int64", Scalar::kI64},       {"int64_t", Scalar::kI64},
      {"ulonglong", Scalar::kU64},          {"unsigned long long", Scalar::kU64},
      {"unsigned long long int", Scalar::kU64}, {"uint64", Scalar::kU64},    {"uint64_t", Scalar::kU64},
      {"float", Scalar::kF32},              {"double", Scalar::kF64}};
  auto it = types.find(lower(value));
  if (it != types.end()) return it->second;
  throw InputError(path, "type", "unsupported type '" + value + "'");
}

// The world frame of `space`/`space dimension`: its dimension, and which of x, y to negate
// to reach LPS.
struct NrrdSpace {
  int dims = 0;  // 0: no world space given
  bool negate_x = false, negate_y = false;
};

// Reads `space` (named frames) or `space dimension` (a bare frame, read as LPS).
NrrdSpace nrrd_space(const NrrdHeader& h, const std::string& path) {
  NrrdSpace s;
  if (const std::string* name = nrrd_field(h, "space")) {
    const std::string n = lower(*name);
    if (n == "left-posterior-superior" || n == "lps" || n == "3d-right-handed") s.dims = 3;
    else if (n == "right-anterior-superior" || n == "ras") s = {3, true, true};
    else if (n == "left-anterior-superior" || n == "las") s = {3, false, true};
    else if (n.find("time") != std::string::npos)
      throw InputError(path, "space", "time series ('" + *name + "') are not supported");
    else
      throw InputError(path, "space",
                       "unsupported space '" + *name + "' (expected LPS, RAS, LAS or 3D-right-handed)");
    if (const std::string* d = nrrd_field(h, "space dimension"))
      if (nrrd_integer(*d, path, "space dimension", 1, 16) != 3)
        throw InputError(path, "space dimension", "must be 3 for space '" + *name + "'");
  } else if (const std::string* d = nrrd_field(h, "space dimension")) {
    s.dims = int(nrrd_integer(*d, path, "space dimension", 2, 3));
  }
  return s;
}

// True if axis `a` holds the components of a value, not a position: its kind is one of NRRD's
// range kinds (vector, normal, list, the colours, the matrices, complex, ...: anything but the
// domain kinds "domain", "space" and "time" and the unknown "???" / "none"), or its space
// direction is "none".
bool is_vector_axis(const std::vector<std::string>& kinds, const std::vector<std::string>& directions, int a) {
  if (a < int(kinds.size())) {
    const std::string k = lower(kinds[a]);
    if (k != "domain" && k != "space" && k != "time" && k != "???" && k != "none") return true;
  }
  return a < int(directions.size()) && lower(directions[a]) == "none";
}

// Spacing, origin and axes of the spatial axes from `space directions` and `space origin`
// (converted to LPS), or from `spacings` and `axis mins` when no world space is given.
void nrrd_placement(const NrrdHeader& h, const std::string& path, const NrrdSpace& space, int lead, int n,
                    const std::vector<std::string>& directions, RawVolume& v) {
  const double flip[3] = {space.negate_x ? -1.0 : 1.0, space.negate_y ? -1.0 : 1.0, 1.0};
  if (space.dims > 0 && !directions.empty()) {
    v.spacing_key = "space directions";
    for (int a = 0; a < n; ++a) {
      const auto d = nrrd_vector(directions[lead + a], path, "space directions", space.dims);
      double norm = 0;
      for (double x : d) norm += x * x;
      norm = std::sqrt(norm);
      // (A NaN or infinite component, or a vector too long for a double, is named as such, not as
      // a vector without length.)
      const std::string axis = "axis " + std::to_string(lead + a);
      for (int k = 0; k < space.dims; ++k)
        if (!std::isfinite(d[k]))
          throw InputError(path, "space directions", axis + "'s vector has a component that is not a finite number (" +
                                                         exact(d[k]) + ")");
      if (!std::isfinite(norm))
        throw InputError(path, "space directions", axis + "'s vector is too long (its length overflows a double)");
      if (!(norm > 0)) throw InputError(path, "space directions", axis + " has no length");
      v.spacing[a] = norm;
      for (int k = 0; k < space.dims; ++k) v.axes[a][k] = flip[k] * d[k] / norm;
    }
  } else if (const std::string* sp = nrrd_field(h, "spacings")) {
    v.spacing_key = "spacings";
    const auto w = words_of(*sp);
    if (int(w.size()) != lead + n) throw InputError(path, "spacings", "expected one number per axis");
    for (int a = 0; a < n; ++a) v.spacing[a] = nrrd_number(w[lead + a], path, "spacings");
  }
  if (space.dims > 0) {
    if (const std::string* o = nrrd_field(h, "space origin")) {
      const auto org = nrrd_vector(strip(*o), path, "space origin", space.dims);
      for (int k = 0; k < space.dims; ++k) v.origin[k] = flip[k] * org[k];
    }
  } else if (const std::string* m = nrrd_field(h, "axis mins")) {
    const auto w = words_of(*m);
    if (int(w.size()) != lead + n) throw InputError(path, "axis mins", "expected one number per axis");
    for (int a = 0; a < n; ++a) v.origin[a] = nrrd_number(w[lead + a], path, "axis mins");
  }
  if (n == 2 && v.ndims == 3) {  // a slice in 3D space: its normal is the third axis
    const auto& x = v.axes[0];
    const auto& y = v.axes[1];
    std::array<double, 3> z{x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]};
    const double len = std::sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    if (!(len > 0)) throw InputError(path, "space directions", "the two axes are parallel");
    for (double& c : z) c /= len;
    v.axes[2] = z;
  }
}

// The geometry of a NRRD header: dimension, sizes, channels (a leading vector axis), spacing,
// origin and axes, all checked.
RawVolume nrrd_geometry(const NrrdHeader& h, const std::string& path) {
  RawVolume v;
  v.channel_key = "kinds";
  const int dim = int(nrrd_integer(required_field(h, "dimension", path), path, "dimension", 1, 16));
  const auto sizes = words_of(required_field(h, "sizes", path));
  if (int(sizes.size()) != dim)
    throw InputError(path, "sizes", "expected " + std::to_string(dim) + " sizes (dimension), found " +
                                        std::to_string(sizes.size()));
  const auto kinds = nrrd_field(h, "kinds") ? words_of(*nrrd_field(h, "kinds")) : std::vector<std::string>{};
  const NrrdSpace space = nrrd_space(h, path);
  const auto directions = nrrd_field(h, "space directions") ? vector_tokens(*nrrd_field(h, "space directions"))
                                                            : std::vector<std::string>{};
  if (!directions.empty() && int(directions.size()) != dim)
    throw InputError(path, "space directions", "expected one entry per axis (" + std::to_string(dim) + ")");
  for (int a = 0; a < int(kinds.size()) && a < dim; ++a)
    if (lower(kinds[a]) == "time")
      throw InputError(path, "kinds", "axis " + std::to_string(a) + " is time: time series are not supported");
  const int lead = dim > 2 && is_vector_axis(kinds, directions, 0) ? 1 : 0;
  for (int a = lead; a < dim; ++a)
    if (is_vector_axis(kinds, directions, a))
      throw InputError(path, "kinds",
                       "only the first axis may be a vector axis (axis " + std::to_string(a) + " is not spatial)");
  const int spatial = dim - lead;
  if (spatial != 2 && spatial != 3)
    throw InputError(path, "dimension",
                     "unsupported dimension " + std::to_string(dim) + " (expected 2 or 3 spatial axes)");
  if (space.dims > 0 && spatial > space.dims)
    throw InputError(path, "space dimension", "the image has " + std::to_string(spatial) + " spatial axes, its space " +
                                                  std::to_string(space.dims));
  v.ndims = std::max(spatial, space.dims);
  if (lead) v.channels = int(nrrd_integer(sizes[0], path, "sizes", 1, 3));
  for (int a = 0; a < spatial; ++a) v.size[a] = nrrd_integer(sizes[lead + a], path, "sizes", 1, kMaxAxisSize);
  nrrd_placement(h, path, space, lead, spatial, directions, v);
  return v;
}

// Where `path`'s data is: the file (`path` itself, after the header, or the `data file`), the
// byte it starts at past `line skip` lines, and the bytes from there to the file's end. Lines are
// counted a block at a time from the file (the data is never read whole for this).
struct NrrdDataSpan {
  std::string where;
  uint64_t offset = 0, length = 0;
};
NrrdDataSpan nrrd_data_span(const NrrdHeader& h, const std::string& path) {
  const std::string* df = nrrd_field(h, "data file");
  NrrdDataSpan span;
  span.where = path;
  std::error_code ec;
  if (df) {
    const auto w = words_of(*df);
    if (w.size() != 1 || w[0] == "LIST")
      throw InputError(path, "data file", "lists and patterns of data files are not supported");
    const fs::path p(w[0]);
    span.where = (p.is_absolute() ? p : fs::path(path).parent_path() / p).string();
    if (!fs::is_regular_file(span.where, ec))
      throw InputError(path, "data file", "data file '" + span.where + "' not found");
    // A detached header naming itself would read its own text as voxels.
    if (fs::equivalent(span.where, path, ec))
      throw InputError(path, "data file", "names the header itself ('" + w[0] +
                                              "'): a detached header's data is another file");
  } else {
    if (h.data_start == std::string::npos)
      throw InputError(path, "data file", "missing: no 'data file' field and no data after the header");
    span.offset = h.data_start;
  }
  const uintmax_t size = fs::file_size(span.where, ec);
  const uint64_t end = ec ? 0 : uint64_t(size);
  if (const std::string* ls = nrrd_field(h, "line skip")) {
    const int64_t n = nrrd_integer(*ls, path, "line skip", 0, 1 << 20);
    std::ifstream in(span.where, std::ios::binary);
    in.seekg(std::streamoff(std::min(span.offset, end)));
    char block[1 << 16];
    for (int64_t lines = 0; lines < n;) {
      in.read(block, sizeof(block));
      const size_t got = size_t(in.gcount());
      if (got == 0) throw InputError(path, "line skip", "the data has fewer lines than skipped");
      size_t k = 0;
      for (; k < got && lines < n; ++k) lines += block[k] == '\n';
      span.offset += k;
    }
  }
  span.length = end > span.offset ? end - span.offset : 0;
  return span;
}

// The `count` values of `type` the data holds (decoded from the encoding, `byte skip` applied),
// into `values`, or an InputError naming the field whose numbers the data does not hold. Raw
// data is read from its file straight into the values, gzip data read from its file and decoded
// as it is inflated (the stored or inflated bytes are never held whole).
void nrrd_values(const NrrdHeader& h, const std::string& path, int64_t count, Scalar type, bool swap,
                 std::vector<float>& values) {
  const double expected = double(count) * scalar_bytes(type);
  const std::string encoding = lower(required_field(h, "encoding", path));
  const bool gz = encoding == "gzip" || encoding == "gz";
  if (!gz && encoding != "raw")
    throw InputError(path, "encoding", "unsupported encoding '" + encoding + "' (expected raw or gzip)");
  int64_t skip = 0;
  if (const std::string* bs = nrrd_field(h, "byte skip"))
    skip = nrrd_integer(*bs, path, "byte skip", gz ? 0 : -1, int64_t(1) << 40);
  const NrrdDataSpan span = nrrd_data_span(h, path);
  const std::string in_file = span.where == path ? "" : " in " + span.where;
  auto too_short = [&](int64_t found) {
    return InputError(path, "sizes", "sizes and type need " + exact(expected) + " bytes of data, found " +
                                         std::to_string(std::max<int64_t>(0, found)) + in_file +
                                         " (truncated data or wrong sizes)");
  };
  if (gz) {
    if (expected + double(skip) > kMaxInflateRatio * double(span.length) + 1024)
      throw InputError(path, "sizes", "sizes and type need " + exact(expected) + " bytes, more than the " +
                                          std::to_string(span.length) + " gzip bytes" + in_file + " can hold");
    const size_t found = inflate_file_values(span.where, span.offset, span.length, size_t(skip), count, type, swap,
                                             values, "encoding", "gzip");
    if (double(found) < expected) throw too_short(int64_t(found));
    return;
  }
  if (skip == -1) skip = std::max<int64_t>(0, int64_t(span.length) - int64_t(expected));
  if (double(span.length) < expected + double(skip)) throw too_short(int64_t(span.length) - skip);
  read_stored_values(span.where, span.offset + uint64_t(skip), count, type, swap, values);
}

}  // namespace

// gzip-wrapped deflate of `parts`, one after another (NRRD's gzip encoding, .nii.gz, .inr.gz),
// at zlib's fastest level, as nibabel writes .nii.gz by default: a volume's file is written at
// every run (result_mask.nii.gz), and level 6 took 2.5 to 3 times as long for files a third of
// the size (the lung phantom's 21 MB image: 0.078 s for 77 kB against 0.028 s for 188 kB). The
// output leaves a piece at a time (to the file being written), so that the compressed bytes are
// never held whole.
void gzip_into(const std::vector<std::string_view>& parts, const std::string& path,
               const std::function<void(std::string_view)>& put) {
  z_stream zs{};
  if (deflateInit2(&zs, Z_BEST_SPEED, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error(path + ": zlib initialisation failed");
  // zlib counts in 32-bit uInt: input is fed at most 1 GiB at a time, so that volumes larger
  // than 4 GiB compress too; output leaves in pieces of 1 MB.
  constexpr size_t kChunk = size_t(1) << 30;
  std::string out(size_t(1) << 20, '\0');
  // Deflates `n` bytes at `in` (with Z_FINISH: then until the stream ends), handing each full
  // piece of output (and the last) to put.
  auto feed = [&](const char* in, size_t n, int flush) {
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in));
    zs.avail_in = uInt(n);
    for (;;) {
      zs.next_out = reinterpret_cast<Bytef*>(out.data());
      zs.avail_out = uInt(out.size());
      const int ret = deflate(&zs, flush);
      if (ret == Z_STREAM_ERROR) {
        deflateEnd(&zs);
        throw std::runtime_error(path + ": gzip compression failed");
      }
      const size_t made = out.size() - zs.avail_out;
      if (made > 0) {
        try {
          put(std::string_view(out.data(), made));
        } catch (...) {
          deflateEnd(&zs);
          throw;
        }
      }
      if (flush == Z_FINISH ? ret == Z_STREAM_END : zs.avail_in == 0 && zs.avail_out > 0) return;
    }
  };
  for (const std::string_view part : parts)
    for (size_t at = 0; at < part.size(); at += kChunk) feed(part.data() + at, std::min(kChunk, part.size() - at), Z_NO_FLUSH);
  feed(nullptr, 0, Z_FINISH);
  deflateEnd(&zs);
}

std::string gzip_bytes(const std::vector<std::string_view>& parts, const std::string& path) {
  std::string bytes;
  gzip_into(parts, path, [&](std::string_view piece) { bytes.append(piece); });
  return bytes;
}

namespace {

// "(a,b[,c])" of the first n numbers.
std::string vector_text(const std::array<double, 3>& a, int n) {
  std::string s = "(";
  for (int i = 0; i < n; ++i) s += (i ? "," : "") + exact(a[i]);
  return s + ")";
}

}  // namespace

// Reads a .nrrd or .nhdr file completely.
RawVolume read_nrrd(const std::string& path) {
  // (Ended at the blank line before attached data; a detached header is a short file, read whole.)
  const NrrdHeader h = parse_header_of(
      path, [&](const std::string& bytes) { return parse_nrrd_header(bytes, path); },
      [](const NrrdHeader& n, const std::string&) { return n.data_start != std::string::npos; });
  RawVolume v = nrrd_geometry(h, path);
  const Scalar type = nrrd_type(required_field(h, "type", path), path);
  bool swap = false;
  if (scalar_bytes(type) > 1) {
    const std::string endian = lower(required_field(h, "endian", path));
    if (endian != "little" && endian != "big")
      throw InputError(path, "endian", "expected little or big, found '" + endian + "'");
    swap = (endian == "big") != (std::endian::native == std::endian::big);
  }
  const double count = double(v.size[0]) * double(v.size[1]) * double(v.size[2]) * v.channels;
  const double expected = count * scalar_bytes(type);
  if (expected > kMaxDataBytes) throw InputError(path, "sizes", "absurd sizes (" + exact(count) + " values)");
  check_declared_values(count, path, "sizes");
  nrrd_values(h, path, int64_t(count), type, swap, v.values);
  return v;
}

// The number of dimensions of a NRRD image from its header (the first MiB of the file).
int nrrd_dimension(const std::string& path) {
  const std::string head = read_bytes(path, 1 << 20);
  return nrrd_geometry(parse_nrrd_header(head, path), path).effective_dimension();
}

// Writes float32 (uint8 for a label map) little-endian NRRD in LPS: .nrrd with the data attached, .nhdr with the data
// in <stem>.raw (or <stem>.raw.gz) beside it; gzip encoding when `compress`.
void write_nrrd(const RawVolume& v, const std::string& path, bool compress) {
  const int n = v.ndims;
  const bool vec = v.channels > 1;
  std::string h = std::string("NRRD0004\n# written by dsnake\ntype: ") + (v.label ? "uint8" : "float") + "\ndimension: " + std::to_string(n + (vec ? 1 : 0)) + "\n";
  h += n == 3 ? "space: left-posterior-superior\n" : "space dimension: 2\n";
  h += "sizes:" + (vec ? " " + std::to_string(v.channels) : std::string());
  for (int a = 0; a < n; ++a) h += " " + std::to_string(v.size[a]);
  h += std::string("\nspace directions:") + (vec ? " none" : "");
  for (int a = 0; a < n; ++a) {
    std::array<double, 3> d{};
    for (int k = 0; k < n; ++k) d[k] = v.axes[a][k] * v.spacing[a];
    h += " " + vector_text(d, n);
  }
  h += std::string("\nkinds:") + (vec ? " vector" : "") + (n == 3 ? " domain domain domain" : " domain domain");
  h += "\nendian: little\nencoding: " + std::string(compress ? "gzip" : "raw") + "\n";
  h += "space origin: " + vector_text(v.origin, n) + "\n";
  std::string converted;
  const std::string_view values = stored_view(v.data(), v.label, converted);
  const bool attached = extension_of(path) != ".nhdr";
  // The header (when attached), then the values or their gzip stream as it is made.
  auto produce = [&](const std::function<void(std::string_view)>& put) {
    if (attached) put(h + "\n");
    if (compress) gzip_into({values}, path, put);
    else put(values);
  };
  if (attached) {
    write_stream_atomically(path, produce);
    return;
  }
  const fs::path p(path);
  const std::string data_name = p.stem().string() + (compress ? ".raw.gz" : ".raw");
  write_stream_atomically((p.parent_path() / data_name).string(), produce);
  write_file_atomically(path, h + "data file: " + data_name + "\n");
}

}  // namespace dsnake::detail
