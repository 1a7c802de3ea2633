// Template, snake and contour I/O. OFF, OBJ and legacy VTK are parsed here (so that a
// non-manifold face is reported, not silently dropped as OpenMesh's reader does); PLY and STL
// go through OpenMesh. Every mesh is checked closed and manifold and turned outward; every
// writer is atomic (framework/core/atomic_file.h) and prints coordinates with 17 significant digits
// so that text round trips are exact.
#include "framework/io/mesh_io.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/core/json_text.h"

#include <Eigen/Geometry>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>

namespace dsnake {

namespace {

namespace fs = std::filesystem;

struct DoublePointTraits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<DoublePointTraits>;

// Lower-case extension of a file name.
std::string extension_of(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// Whole text file, or InputError when it is missing.
std::string read_text(const std::string& path) {
  require_regular_file(path, "mesh or contour file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A double printed so that it reads back exactly.
std::string exact(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

// Parses a whole token as a number; false if it is not one.
bool parse_number(const std::string& tok, double& value) {
  char* end = nullptr;
  value = std::strtod(tok.c_str(), &end);
  return !tok.empty() && end != tok.c_str() && *end == '\0';
}

// Blank-separated words of a line.
std::vector<std::string> split_words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string t; in >> t;) w.push_back(t);
  return w;
}

// Lines of a text file with '#' comments removed, keeping 1-based line numbers.
std::vector<std::pair<int, std::string>> content_lines(const std::string& text) {
  std::vector<std::pair<int, std::string>> lines;
  std::istringstream in(text);
  int no = 0;
  for (std::string line; std::getline(in, line);) {
    ++no;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    // the same blanks as split_words' >> (a line of only '\v' is empty: found by fuzzing)
    if (line.find_first_not_of(" \t\r\n\v\f") != std::string::npos) lines.emplace_back(no, line);
  }
  return lines;
}

// Appends the fan triangulation of a polygon (v0, v1, v2), (v0, v2, v3), ...
void add_fan(const std::vector<int>& poly, std::vector<Triangle>& tris) {
  for (size_t k = 1; k + 1 < poly.size(); ++k) tris.push_back({poly[0], poly[k], poly[k + 1]});
}

// ---------------------------------------------------------------- mesh readers

// Positions and triangles as read, before the checks.
struct RawMesh {
  PointList<3> points;
  std::vector<Triangle> triangles;
};

// ASCII OFF: "OFF", counts "nv nf ne", nv vertex lines, nf face lines "k i1 ... ik".
RawMesh read_off(const std::string& path) {
  const auto lines = content_lines(read_text(path));
  RawMesh m;
  if (lines.empty()) return m;
  // The keyword, then "nv nf ne" on the same line or the next.
  auto words = split_words(lines[0].second);
  if (words[0].size() < 3 || !words[0].ends_with("OFF"))
    throw InputError(path, "header", "not an ASCII OFF file (expected the keyword OFF)");
  size_t first = 1;
  words.erase(words.begin());
  if (words.empty() && lines.size() > 1) words = split_words(lines[first++].second);
  double counts[2] = {-1, -1};
  if (words.size() < 2 || !parse_number(words[0], counts[0]) || !parse_number(words[1], counts[1]) || counts[0] < 0 ||
      counts[1] < 0)
    throw InputError(path, "counts", "expected the vertex and face counts");
  // Counts are compared with the lines there are before any conversion to int (fuzzing: 1e300).
  if (counts[0] != std::floor(counts[0]) || counts[1] != std::floor(counts[1]))
    throw InputError(path, "counts", "the vertex and face counts must be whole numbers");
  if (double(lines.size()) < double(first) + counts[0] + counts[1]) throw InputError(path, "", "unexpected end of file");
  const int nv = int(counts[0]), nf = int(counts[1]);
  const size_t line_of_counts = first - 1;
  for (int v = 0; v < nv; ++v) {
    const auto w = split_words(lines[line_of_counts + 1 + v].second);
    Point<3> p;
    for (int a = 0; a < 3; ++a)
      if (a >= int(w.size()) || !parse_number(w[a], p[a]))
        throw InputError(path, "vertex " + std::to_string(v), "expected three coordinates");
    m.points.push_back(p);
  }
  for (int f = 0; f < nf; ++f) {
    const auto w = split_words(lines[line_of_counts + 1 + nv + f].second);
    double k = 0;
    if (w.empty() || !parse_number(w[0], k) || !(k >= 3) || double(w.size()) < 1 + k)
      throw InputError(path, "face " + std::to_string(f), "expected a vertex count >= 3 and the vertex indices");
    std::vector<int> poly;
    for (int i = 1; i <= int(k); ++i) {
      double id;
      if (!parse_number(w[i], id) || id < 0 || id >= nv || id != std::floor(id))
        throw InputError(path, "face " + std::to_string(f), "vertex index '" + w[i] + "' out of range");
      poly.push_back(int(id));
    }
    add_fan(poly, m.triangles);
  }
  return m;
}

// ASCII OBJ: "v x y z" and "f a b c ..." lines (a may be "a/t/n"; negative = relative).
RawMesh read_obj(const std::string& path) {
  RawMesh m;
  for (const auto& [no, line] : content_lines(read_text(path))) {
    const auto w = split_words(line);  // not empty: content_lines keeps lines with a word
    const std::string where = "line " + std::to_string(no);
    if (w.empty()) continue;
    if (w[0] == "v") {
      Point<3> p;
      for (int a = 0; a < 3; ++a)
        if (int(w.size()) < 4 || !parse_number(w[a + 1], p[a]))
          throw InputError(path, where, "expected three vertex coordinates");
      m.points.push_back(p);
    } else if (w[0] == "f") {
      if (w.size() < 4) throw InputError(path, where, "a face needs at least three vertices");
      std::vector<int> poly;
      for (size_t i = 1; i < w.size(); ++i) {
        double id;
        if (!parse_number(w[i].substr(0, w[i].find('/')), id) || id == 0 || id != std::floor(id))
          throw InputError(path, where, "bad vertex reference '" + w[i] + "'");
        if (!(std::abs(id) <= double(m.points.size())))  // before the conversion to int (fuzzing: 1e300)
          throw InputError(path, where, "vertex reference '" + w[i] + "' out of range");
        const int v = id > 0 ? int(id) - 1 : int(m.points.size()) + int(id);
        if (v < 0 || v >= int(m.points.size())) throw InputError(path, where, "vertex reference '" + w[i] + "' out of range");
        poly.push_back(v);
      }
      add_fan(poly, m.triangles);
    }
  }
  return m;
}

// Legacy ASCII VTK POLYDATA: POINTS, then POLYGONS and/or LINES (cells as index lists).
struct VtkPolyData {
  PointList<3> points;
  std::vector<std::vector<int>> polygons, lines;
};

// Reads the geometry part of a legacy ASCII VTK POLYDATA file (attributes are skipped).
VtkPolyData read_vtk(const std::string& path) {
  const std::string text = read_text(path);
  std::istringstream in(text);
  std::string line;
  VtkPolyData d;
  if (!std::getline(in, line)) return d;
  if (line.rfind("# vtk DataFile", 0) != 0) throw InputError(path, "header", "not a legacy VTK file");
  std::getline(in, line);  // title
  std::string word;
  if (!(in >> word) || word != "ASCII") throw InputError(path, "header", "only ASCII VTK files are supported");
  if (!(in >> word >> line) || word != "DATASET" || line != "POLYDATA")
    throw InputError(path, "DATASET", "expected DATASET POLYDATA");
  auto count = [&](const std::string& key) {
    double d;
    std::string t;
    if (!(in >> t) || !parse_number(t, d) || !(d >= 0) || d != std::floor(d)) throw InputError(path, key, "expected a count");
    // Nothing in the file takes less than a byte, so a count past its size is a lie: refused before
    // any allocation or conversion (fuzzing: POINTS 1e300).
    if (d > double(text.size())) throw InputError(path, key, "the count " + t + " is larger than the file");
    return int64_t(d);
  };
  while (in >> word) {
    if (word == "POINTS") {
      const int64_t n = count("POINTS");
      in >> word;  // data type; values are read as doubles
      d.points.resize(n);
      for (int64_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
          std::string t;
          if (!(in >> t) || !parse_number(t, d.points[i][a]))
            throw InputError(path, "POINTS", "point " + std::to_string(i) + ": expected three numbers");
        }
    } else if (word == "POLYGONS" || word == "LINES" || word == "VERTICES" || word == "TRIANGLE_STRIPS") {
      const std::string key = word;
      const int64_t cells = count(key);
      count(key);
      auto& out = key == "POLYGONS" ? d.polygons : d.lines;
      for (int64_t c = 0; c < cells; ++c) {
        const int64_t k = count(key);
        std::vector<int> cell;
        for (int64_t i = 0; i < k; ++i) {
          std::string t;
          double v;
          if (!(in >> t) || !parse_number(t, v) || !(v >= 0) || v != std::floor(v))
            throw InputError(path, key,
                             "cell " + std::to_string(c) + ": '" + t + "' is not a point index (a whole number from 0)");
          if (!(v < double(d.points.size())))
            throw InputError(path, key, "cell " + std::to_string(c) + " refers to point " + t + ", of " +
                                            std::to_string(d.points.size()) + " points");
          cell.push_back(int(v));
        }
        if (key == "TRIANGLE_STRIPS") throw InputError(path, key, "triangle strips are not supported");
        if (key != "VERTICES") out.push_back(std::move(cell));
      }
    } else if (word == "POINT_DATA" || word == "CELL_DATA" || word == "METADATA" || word == "FIELD") {
      break;  // attributes are not part of the shape
    } else {
      throw InputError(path, word, "unexpected keyword in a POLYDATA file");
    }
  }
  return d;
}

// An element of a PLY header: its name, its count and, per property, whether it is a list (a
// count, then items) or one value.
struct PlyElement {
  std::string name;
  int64_t count = 0;
  std::vector<bool> list;
  // Per property, in a binary body: the bytes of a list's count (0 for a single value), whether
  // that count is signed, the bytes of the value (of each item of a list) and whether it is signed.
  std::vector<std::array<int, 4>> bytes;
  // Per property: a face's vertex indices (its items must be vertex numbers).
  std::vector<bool> vertex_indices;
};

// InputError for face `face`'s item `index` that is not the number of one of the file's
// `vertices` vertices: OpenMesh dropped such a face without a word, and the mesh was then refused
// as not closed.
void check_ply_vertex_index(double index, int64_t face, int64_t vertices, const std::string& path) {
  if (index >= 0 && index < double(vertices) && index == std::floor(index)) return;
  throw InputError(path, "face " + std::to_string(face),
                   "refers to vertex " + exact(index) + " of " + std::to_string(vertices) + " vertices (numbered from 0)");
}

// The number of vertices a PLY header declares (0 without a vertex element).
int64_t ply_vertex_count(const std::vector<PlyElement>& elements) {
  for (const PlyElement& e : elements)
    if (e.name == "vertex") return e.count;
  return 0;
}

// Bytes of a PLY scalar type (those check_ply_header accepts), 0 for a name that is not one.
int ply_type_bytes(const std::string& type) {
  static const std::map<std::string, int> kBytes = {
      {"char", 1},  {"uchar", 1}, {"int8", 1},   {"uint8", 1},  {"short", 2},   {"ushort", 2},  {"int16", 2},   {"uint16", 2},
      {"int", 4},   {"uint", 4},  {"int32", 4},  {"uint32", 4}, {"float", 4},   {"float32", 4}, {"double", 8},  {"float64", 8}};
  const auto it = kBytes.find(type);
  return it == kBytes.end() ? 0 : it->second;
}
// True for the integer types among them.
bool ply_integer_type(const std::string& type) {
  return ply_type_bytes(type) > 0 && type != "float" && type != "float32" && type != "double" && type != "float64";
}

// A binary PLY body against the header: every list's count is read and must be within what the
// file holds, and the file must hold every element (OpenMesh's binary reader allocated and looped
// on the count it read, a negative or huge one taking gigabytes and minutes).
void check_ply_binary_body(std::istream& in, const std::string& path, const std::vector<PlyElement>& elements,
                           bool big_endian) {
  const std::string body{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  const int64_t vertices = ply_vertex_count(elements);
  // The unsigned or signed integer of `n` bytes at body[at], in the file's byte order.
  auto integer = [&](size_t at, int n, bool is_signed) {
    uint64_t raw = 0;
    for (int b = 0; b < n; ++b) raw |= uint64_t(uint8_t(body[at + size_t(big_endian ? n - 1 - b : b)])) << (8 * b);
    int64_t value = int64_t(raw);
    if (is_signed && n < 8 && (raw >> (8 * n - 1) & 1)) value -= int64_t(1) << (8 * n);
    return value;
  };
  size_t at = 0;
  for (const PlyElement& e : elements)
    for (int64_t i = 0; i < e.count; ++i)
      for (size_t p = 0; p < e.bytes.size(); ++p) {
        const auto [count_bytes, count_signed, value_bytes, value_signed] = e.bytes[p];
        const std::string where = "element " + e.name;
        auto ends = [&] {
          return InputError(path, where, "the file ends inside entry " + std::to_string(i) + " of its " +
                                             std::to_string(e.count));
        };
        if (count_bytes == 0) {
          if (body.size() - at < size_t(value_bytes)) throw ends();
          at += size_t(value_bytes);
          continue;
        }
        if (body.size() - at < size_t(count_bytes)) throw ends();
        const int64_t items = integer(at, count_bytes, count_signed);
        at += size_t(count_bytes);
        if (items < 0 || uint64_t(items) > (body.size() - at) / uint64_t(value_bytes))
          throw InputError(path, where, "entry " + std::to_string(i) + " has a list of " + std::to_string(items) +
                                            " items: negative, or more than the file holds");
        if (e.vertex_indices[p])
          for (int64_t k = 0; k < items; ++k)
            check_ply_vertex_index(double(integer(at + size_t(k * value_bytes), value_bytes, value_signed)), i, vertices,
                                   path);
        at += size_t(items) * size_t(value_bytes);
      }
}

// An ASCII PLY body, line by line against the header (OpenMesh's ASCII reader looped without end
// on a face line of the wrong length: found by fuzzing). Counts are bounded by the file size.
// `line_no` is the number of the header's last line.
void check_ply_ascii_body(std::istream& in, const std::string& path, const std::vector<PlyElement>& elements,
                          int64_t line_no) {
  const int64_t vertices = ply_vertex_count(elements);
  for (const PlyElement& e : elements)
    for (int64_t i = 0; i < e.count; ++i) {
      std::string body;
      do {
        if (!std::getline(in, body))
          throw InputError(path, "element " + e.name, "the file ends after " + std::to_string(i) + " of its " +
                                                          std::to_string(e.count) + " lines");
        ++line_no;
      } while (body.find_first_not_of(" \t\r\n\v\f") == std::string::npos);
      const auto w = split_words(body);
      size_t k = 0;
      bool ok = true;
      double v = 0;
      for (size_t p = 0; ok && p < e.list.size(); ++p) {
        if (!e.list[p]) {
          ok = k < w.size() && parse_number(w[k++], v);
          continue;
        }
        ok = k < w.size() && parse_number(w[k++], v) && v >= 0 && v == std::floor(v) && v <= double(w.size() - k);
        const int64_t items = ok ? int64_t(v) : 0;  // bounded by the words left on the line
        for (int64_t j = 0; ok && j < items; ++j) {
          ok = parse_number(w[k++], v);
          if (ok && e.vertex_indices[p]) check_ply_vertex_index(v, i, vertices, path);
        }
      }
      if (!ok || k != w.size())
        throw InputError(path, "line " + std::to_string(line_no),
                         "does not match the header's '" + e.name + "' properties: '" + body.substr(0, 80) + "'");
    }
}

// A PLY header, read strictly before OpenMesh sees the file: every line is a format,
// comment, obj_info, element or property line of known types, and end_header comes within 10 000
// lines (without it OpenMesh's reader never returned: found by fuzzing). Element counts are
// checked against the file's size before OpenMesh allocates them (a header declaring 2e9 vertices
// ended in bad_alloc): a vertex takes at least 3 bytes (three 1-byte coordinates) and a face at
// least 4 (a count and three 1-byte indices), in ASCII more.
void check_ply_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  if (!std::getline(in, line) || line.rfind("ply", 0) != 0) throw InputError(path, "", "not a PLY file (no 'ply' magic)");
  std::error_code ec;
  const double size = double(fs::file_size(path, ec));
  double need = 0;
  bool in_element = false, format = false, ascii = false, big_endian = false;
  std::vector<PlyElement> elements;
  static const std::set<std::string> kTypes = {"char",  "uchar",  "short",  "ushort", "int",    "uint",
                                               "float", "double", "int8",   "uint8",  "int16",  "uint16",
                                               "int32", "uint32", "float32", "float64"};
  for (int n = 2; n < 10000 && std::getline(in, line); ++n) {
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    const std::string where = "header line " + std::to_string(n);
    auto bad = [&](const std::string& why) { return InputError(path, where, why + ": '" + line.substr(0, 80) + "'"); };
    std::istringstream words(line);
    std::string keyword, a, b, c, extra;
    words >> keyword;
    if (keyword == "end_header") {
      if (!format) throw bad("no 'format' line before the end of the header");
      // OpenMesh's header reader also looped on a version that is not a number and on a header
      // without elements (fuzzing): a vertex element and a property on every element are required.
      if (std::none_of(elements.begin(), elements.end(), [](const PlyElement& e) { return e.name == "vertex"; }))
        throw bad("no 'element vertex' line before the end of the header");
      for (const PlyElement& e : elements)
        if (e.list.empty()) throw InputError(path, "element " + e.name, "has no property lines");
      if (ascii) check_ply_ascii_body(in, path, elements, n);
      else check_ply_binary_body(in, path, elements, big_endian);
      return;
    }
    if (keyword == "comment" || keyword == "obj_info" || keyword.empty()) continue;
    if (keyword == "format") {
      if (!(words >> a >> b) || (words >> extra) || b != "1.0" ||
          (a != "ascii" && a != "binary_little_endian" && a != "binary_big_endian"))
        throw bad("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      format = true;
      ascii = a == "ascii";
      big_endian = a == "binary_big_endian";
    } else if (keyword == "element") {
      double count = 0;
      if (!(words >> a >> count) || !(count >= 0) || (words >> extra))
        throw bad("expected 'element NAME COUNT'");
      need += count * (a == "face" ? 4.0 : a == "vertex" ? 3.0 : 1.0);  // every element takes a byte at least
      if (need > size || count != std::floor(count))
        throw InputError(path, "element " + a, "the header declares " + std::to_string(int64_t(std::min(count, 9e18))) + " '" + a +
                                                   "' elements, more than the file's " + std::to_string(int64_t(size)) + " bytes can hold");
      in_element = true;
      elements.push_back({a, int64_t(count), {}, {}, {}});
    } else if (keyword == "property") {
      if (!in_element) throw bad("a property before any element");
      std::string name;  // property TYPE NAME, or property list COUNT_TYPE ITEM_TYPE NAME
      const bool ok = (words >> a) && (a == "list" ? (words >> b >> c >> name) && kTypes.count(b) && kTypes.count(c)
                                                    : (words >> name) && kTypes.count(a) != 0);
      if (!ok || (words >> extra)) throw bad("expected 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
      // A list's count is a whole number, and so are a face's vertex indices (OpenMesh printed a
      // line for every float index it could not convert).
      if (a == "list" && (!ply_integer_type(b) || ((name == "vertex_indices" || name == "vertex_index") && !ply_integer_type(c))))
        throw bad("a list's count type, and a face's index type, must be integer types");
      elements.back().list.push_back(a == "list");
      elements.back().bytes.push_back(a == "list"
                                          ? std::array<int, 4>{ply_type_bytes(b), b[0] != 'u', ply_type_bytes(c), c[0] != 'u'}
                                          : std::array<int, 4>{0, 0, ply_type_bytes(a), a[0] != 'u'});
      elements.back().vertex_indices.push_back(a == "list" && elements.back().name == "face" &&
                                               (name == "vertex_indices" || name == "vertex_index"));
    } else {
      throw bad("not a PLY header line");
    }
  }
  // OpenMesh's reader looks for end_header without end (a hang found by fuzzing).
  throw InputError(path, "header", "no 'end_header' line");
}

// InputError naming the first STL facet with a coordinate that is not a finite number. OpenMesh
// merges an STL's vertices by comparing their coordinates, which a NaN does not order: the mesh it
// made of such a file lost or fused facets, and was refused as not closed (or, worse, read as
// another closed mesh). Binary when the size is that of the facet count at byte 80 (OpenMesh's
// own test), else ASCII, whose "vertex x y z" lines are read.
void check_stl_coordinates(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  auto bad = [&](uint64_t facet, int vertex, const double (&p)[3]) {
    return InputError(path, "facet " + std::to_string(facet),
                      "vertex " + std::to_string(vertex) + " has a coordinate that is not a finite number (" + exact(p[0]) +
                          " " + exact(p[1]) + " " + exact(p[2]) + ")");
  };
  char head[84];
  if (ec || !in.read(head, 84)) return;
  const uint64_t count = uint64_t(uint8_t(head[80])) | uint64_t(uint8_t(head[81])) << 8 |
                         uint64_t(uint8_t(head[82])) << 16 | uint64_t(uint8_t(head[83])) << 24;
  if (size == 84 + 50 * count) {
    char facet[50];
    for (uint64_t f = 0; f < count && in.read(facet, 50); ++f)
      for (int v = 0; v < 3; ++v) {
        double p[3];
        for (int k = 0; k < 3; ++k) {
          float x;
          std::memcpy(&x, facet + 12 + 12 * v + 4 * k, 4);  // little-endian, as this machine's
          p[k] = x;
        }
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) throw bad(f, v, p);
      }
    return;
  }
  in.clear();
  in.seekg(0);
  int64_t facet = -1;
  int vertex = 0;
  for (std::string word; in >> word;) {
    std::transform(word.begin(), word.end(), word.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (word == "facet") {
      ++facet, vertex = 0;
    } else if (word == "vertex") {
      double p[3];
      std::string t;
      for (int k = 0; k < 3; ++k)
        if (!(in >> t) || !parse_number(t, p[k])) return;  // not a number: OpenMesh's to refuse
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        throw bad(uint64_t(std::max<int64_t>(facet, 0)), vertex, p);
      ++vertex;
    }
  }
}

// PLY and STL through OpenMesh (STL vertices shared by several facets are merged on read).
// OpenMesh's own messages are silenced: a failure is our one line.
RawMesh read_openmesh(const std::string& path) {
  require_regular_file(path, "mesh file");
  if (extension_of(path) == ".ply") check_ply_header(path);
  if (extension_of(path) == ".stl") check_stl_coordinates(path);
  OmMesh mesh;
  OpenMesh::IO::Options opt;
  omerr().disable();
  omlog().disable();
  const bool read = OpenMesh::IO::read_mesh(mesh, path, opt);
  omerr().enable();
  omlog().enable();
  if (!read) throw InputError(path, "", "cannot read the mesh (OpenMesh failed)");
  RawMesh m;
  for (const auto& v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    m.points.emplace_back(p[0], p[1], p[2]);
  }
  for (const auto& f : mesh.faces()) {
    std::vector<int> poly;
    for (const auto& v : f.vertices()) poly.push_back(v.idx());
    add_fan(poly, m.triangles);
  }
  return m;
}

// Splits Connectivity's "edge (3, 5) is a boundary edge ..." into element and message.
InputError mesh_problem(const std::string& path, const std::string& problem) {
  size_t k = problem.find(" is ");
  if (k == std::string::npos) k = problem.find(" refers ");
  if (k == std::string::npos) return InputError(path, "", problem);
  return InputError(path, problem.substr(0, k), problem.substr(k + 1));
}

// The connected components of a mesh's triangles: a component index per triangle (vertices
// joined by an edge share one), the vertices of each component, and the number of components.
int triangle_components(int num_vertices, const std::vector<Triangle>& triangles, std::vector<int>& component,
                        std::vector<int>& vertices_per_component) {
  std::vector<int> parent(static_cast<size_t>(num_vertices));
  for (int v = 0; v < num_vertices; ++v) parent[size_t(v)] = v;
  auto root = [&](int v) {
    while (parent[size_t(v)] != v) v = parent[size_t(v)] = parent[size_t(parent[size_t(v)])];
    return v;
  };
  for (const auto& t : triangles)
    for (int k = 1; k < 3; ++k) parent[size_t(root(t[k]))] = root(t[0]);
  std::vector<int> index(static_cast<size_t>(num_vertices), -1);
  int count = 0;
  component.assign(triangles.size(), 0);
  for (size_t i = 0; i < triangles.size(); ++i) {
    int& c = index[size_t(root(triangles[i][0]))];
    if (c < 0) c = count++;
    component[i] = c;
  }
  vertices_per_component.assign(size_t(count), 0);
  for (int v = 0; v < num_vertices; ++v)
    if (const int c = index[size_t(root(v))]; c >= 0) ++vertices_per_component[size_t(c)];
  return count;
}

// Checks a read mesh (non-empty, finite, closed, manifold) and turns it outward. Each connected
// component is turned outward by the sign of its own enclosed volume; a mesh of several
// components and an inward mesh are accepted with a warning line,
// since either may be what the user meant (two lungs; a writer with the other convention).
Template<3> mesh_template(const std::string& path, RawMesh m) {
  if (m.points.empty() || m.triangles.empty()) throw InputError(path, "", "empty template");
  for (size_t v = 0; v < m.points.size(); ++v)
    if (!m.points[v].allFinite()) throw InputError(path, "vertex " + std::to_string(v), "coordinate is NaN or infinite");
  Template<3> t;
  t.positions = std::move(m.points);
  const int n = t.num_vertices();
  t.connectivity = Connectivity::mesh(n, m.triangles);
  if (const std::string problem = t.connectivity.closed_manifold_problem(); !problem.empty())
    throw mesh_problem(path, problem);
  std::vector<int> component, component_vertices;
  const int components = triangle_components(n, m.triangles, component, component_vertices);
  std::vector<double> volume(size_t(components), 0.0);  // six times each component's signed volume
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& tri = m.triangles[i];
    const auto& a = t.positions[size_t(tri[0])];
    volume[size_t(component[i])] += a.dot(t.positions[size_t(tri[1])].cross(t.positions[size_t(tri[2])]));
  }
  if (components > 1) {
    std::string sizes;
    for (int c = 0; c < components && c < 8; ++c) sizes += (c ? ", " : "") + std::to_string(component_vertices[size_t(c)]);
    if (components > 8) sizes += ", ...";
    std::fprintf(stderr,
                 "dsnake: warning: %s: the mesh has %d separate surfaces (%s vertices); each is registered as its "
                 "own closed surface\n",
                 path.c_str(), components, sizes.c_str());
  }
  int inward = 0;
  for (int c = 0; c < components; ++c) inward += volume[size_t(c)] < 0;
  if (inward > 0) {
    for (size_t i = 0; i < m.triangles.size(); ++i)
      if (volume[size_t(component[i])] < 0) std::swap(m.triangles[i][1], m.triangles[i][2]);
    t.connectivity = Connectivity::mesh(n, std::move(m.triangles));
    std::fprintf(stderr,
                 "dsnake: warning: %s: %s inward (negative enclosed volume); turned outward, vertex ids "
                 "unchanged\n",
                 path.c_str(), components == 1 ? "the mesh's triangles face" : "some surfaces' triangles face");
  }
  return t;
}

// ---------------------------------------------------------------- contour readers

// Checks a read contour (>= 3 points, finite, no repeated consecutive point).
Template<2> contour_template(const std::string& path, PointList<2> points, std::map<std::string, int> landmarks) {
  const int n = int(points.size());
  if (n < 3) throw InputError(path, "", "a contour needs at least 3 points, found " + std::to_string(n));
  for (int v = 0; v < n; ++v) {
    if (!points[v].allFinite()) throw InputError(path, "vertex " + std::to_string(v), "coordinate is NaN or infinite");
    if (points[v] == points[(v + 1) % n])
      throw InputError(path, "vertex " + std::to_string(v), "equals the next vertex " + std::to_string((v + 1) % n));
  }
  Template<2> t;
  t.positions = std::move(points);
  t.connectivity = Connectivity::polygon(n);
  t.landmarks = std::move(landmarks);
  return t;
}

// One "x y" per line; '#' comments and blank lines are skipped, ids count the points.
Template<2> read_contour_txt(const std::string& path) {
  PointList<2> pts;
  for (const auto& [no, line] : content_lines(read_text(path))) {
    const auto w = split_words(line);
    Point<2> p;
    if (w.size() != 2 || !parse_number(w[0], p[0]) || !parse_number(w[1], p[1]))
      throw InputError(path, "line " + std::to_string(no), "expected two numbers");
    pts.push_back(p);
  }
  return contour_template(path, std::move(pts), {});
}

// {"points": [[x, y], ...], "landmarks": {"name": id}, "scalars": {...}}; other keys are errors.
Template<2> read_contour_json(const std::string& path) {
  const nlohmann::json j = parse_json_text(read_text(path), path);
  if (!j.is_object()) throw InputError(path, "", "expected a JSON object");
  for (const auto& [key, value] : j.items())
    if (key != "points" && key != "landmarks" && key != "scalars") throw InputError(path, key, "unknown key");
  if (!j.contains("points") || !j["points"].is_array()) throw InputError(path, "points", "an array of [x, y] is required");
  PointList<2> pts;
  for (size_t i = 0; i < j["points"].size(); ++i) {
    const auto& p = j["points"][i];
    if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
      throw InputError(path, "points[" + std::to_string(i) + "]", "expected [x, y]");
    pts.emplace_back(p[0].get<double>(), p[1].get<double>());
  }
  std::map<std::string, int> landmarks;
  if (j.contains("landmarks")) {
    if (!j["landmarks"].is_object()) throw InputError(path, "landmarks", "expected an object {\"name\": id}");
    for (const auto& [name, id] : j["landmarks"].items()) {
      if (!id.is_number_integer() || id.get<int64_t>() < 0 || id.get<int64_t>() >= int64_t(pts.size()))
        throw InputError(path, "landmarks." + name, "expected a vertex id in [0, " + std::to_string(pts.size()) + ")");
      landmarks[name] = id.get<int>();
    }
  }
  if (j.contains("scalars") && !j["scalars"].is_object())
    throw InputError(path, "scalars", "expected an object {\"name\": [values]}");
  return contour_template(path, std::move(pts), std::move(landmarks));
}

// One closed polyline through every point once; the ids follow the line's order.
Template<2> read_contour_vtk(const std::string& path) {
  VtkPolyData d = read_vtk(path);
  if (d.lines.size() != 1) throw InputError(path, "LINES", "expected one polyline, found " + std::to_string(d.lines.size()));
  std::vector<int> line = d.lines[0];
  if (line.size() > 1 && line.front() == line.back()) line.pop_back();
  std::vector<char> seen(d.points.size(), 0);
  for (int id : line)
    if (seen[id]++) throw InputError(path, "LINES", "the polyline visits point " + std::to_string(id) + " twice");
  if (line.size() != d.points.size()) throw InputError(path, "LINES", "the polyline must visit every point");
  PointList<2> pts;
  for (int id : line) pts.emplace_back(d.points[id][0], d.points[id][1]);
  return contour_template(path, std::move(pts), {});
}

// ---------------------------------------------------------------- writers

// POINT_DATA with one SCALARS block per array, or VECTORS for 3 components (names without
// spaces, as VTK requires; every value finite, which VTK's reader needs).
std::string vtk_scalars(const std::vector<VertexScalars>& scalars, size_t n) {
  if (scalars.empty()) return "";
  std::string s = "POINT_DATA " + std::to_string(n) + "\n";
  for (const auto& sc : scalars) {
    const size_t c = size_t(sc.components);
    DSNAKE_ASSERT(c >= 1 && c <= 4 && sc.values.size() == n * c, "components per vertex: " + sc.name);
    DSNAKE_ASSERT(std::all_of(sc.values.begin(), sc.values.end(), [](double v) { return std::isfinite(v); }),
                  "VTK arrays must be finite: " + sc.name);
    std::string name = sc.name.empty() ? "scalars" : sc.name;
    std::replace_if(name.begin(), name.end(), [](unsigned char ch) { return std::isspace(ch); }, '_');
    if (c == 3) s += "VECTORS " + name + " double\n";
    else s += "SCALARS " + name + " double " + std::to_string(c) + "\nLOOKUP_TABLE default\n";
    for (size_t i = 0; i < n; ++i) {
      for (size_t k = 0; k < c; ++k) s += (k ? " " : "") + exact(sc.values[i * c + k]);
      s += "\n";
    }
  }
  return s;
}

// The four header lines of a legacy ASCII POLYDATA file.
std::string vtk_header(const std::string& title) {
  return "# vtk DataFile Version 3.0\n" + title + "\nASCII\nDATASET POLYDATA\n";
}

// PLY (binary, double coordinates) and STL (binary) through OpenMesh.
void write_openmesh(const PointList<3>& points, const Connectivity& c, const std::string& path) {
  OmMesh mesh;
  std::vector<OmMesh::VertexHandle> vh;
  for (const auto& p : points) vh.push_back(mesh.add_vertex(OmMesh::Point(p[0], p[1], p[2])));
  for (const auto& t : c.triangles())
    if (!mesh.add_face(vh[t[0]], vh[t[1]], vh[t[2]]).is_valid())
      throw std::runtime_error(path + ": OpenMesh cannot store a non-manifold triangle");
  OpenMesh::IO::Options opt = OpenMesh::IO::Options::Binary;
  write_via_temporary(path, [&](const std::string& tmp) {
    if (!OpenMesh::IO::write_mesh(mesh, tmp, opt, 17)) throw OutputError(path, "OpenMesh cannot write the mesh");
  });
}

}  // namespace

// Dispatches on the extension; every route ends in mesh_template()'s checks.
Template<3> read_mesh_template(const std::string& path) {
  const std::string ext = extension_of(path);
  if (ext == ".off") return mesh_template(path, read_off(path));
  if (ext == ".obj") return mesh_template(path, read_obj(path));
  if (ext == ".ply" || ext == ".stl") return mesh_template(path, read_openmesh(path));
  if (ext == ".vtk") {
    VtkPolyData d = read_vtk(path);
    RawMesh m;
    m.points = std::move(d.points);
    for (const auto& poly : d.polygons) {
      if (poly.size() < 3) throw InputError(path, "POLYGONS", "a polygon needs at least three points");
      add_fan(poly, m.triangles);
    }
    return mesh_template(path, std::move(m));
  }
  throw InputError(path, "", "unknown mesh format (expected .off, .obj, .ply, .stl or .vtk)");
}

// Dispatches on the extension; every route ends in contour_template()'s checks.
Template<2> read_contour_template(const std::string& path) {
  const std::string ext = extension_of(path);
  if (ext == ".txt") return read_contour_txt(path);
  if (ext == ".json") return read_contour_json(path);
  if (ext == ".vtk") return read_contour_vtk(path);
  throw InputError(path, "", "unknown contour format (expected .txt, .json or .vtk)");
}

// 2D: a contour; 3D: a mesh.
template <int D>
Template<D> read_shape(const std::string& path) {
  if constexpr (D == 2) return read_contour_template(path);
  else return read_mesh_template(path);
}

// Text formats written here with 17 digits; PLY and STL through OpenMesh. Atomic.
void write_mesh(const PointList<3>& points, const Connectivity& c, const std::string& path,
                const std::vector<VertexScalars>& scalars) {
  const std::string ext = extension_of(path);
  const auto& tris = c.triangles();
  std::string s;
  if (ext == ".off") {
    s = "OFF\n" + std::to_string(points.size()) + " " + std::to_string(tris.size()) + " 0\n";
    for (const auto& p : points) s += exact(p[0]) + " " + exact(p[1]) + " " + exact(p[2]) + "\n";
    for (const auto& t : tris) s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  } else if (ext == ".obj") {
    for (const auto& p : points) s += "v " + exact(p[0]) + " " + exact(p[1]) + " " + exact(p[2]) + "\n";
    for (const auto& t : tris)
      s += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " + std::to_string(t[2] + 1) + "\n";
  } else if (ext == ".vtk") {
    s = vtk_header("dsnake mesh") + "POINTS " + std::to_string(points.size()) + " double\n";
    for (const auto& p : points) s += exact(p[0]) + " " + exact(p[1]) + " " + exact(p[2]) + "\n";
    s += "POLYGONS " + std::to_string(tris.size()) + " " + std::to_string(4 * tris.size()) + "\n";
    for (const auto& t : tris) s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
    s += vtk_scalars(scalars, points.size());
  } else if (ext == ".ply" || ext == ".stl") {
    return write_openmesh(points, c, path);
  } else {
    throw InputError(path, "", "unknown mesh format (expected .off, .obj, .ply, .stl or .vtk)");
  }
  write_file_atomically(path, s);
}

// Text, JSON (points + named scalar arrays) or VTK polyline (closing index repeated). Atomic.
void write_contour(const PointList<2>& points, const std::string& path, const std::vector<VertexScalars>& scalars) {
  const std::string ext = extension_of(path);
  const size_t n = points.size();
  std::string s;
  if (ext == ".txt") {
    for (const auto& p : points) s += exact(p[0]) + " " + exact(p[1]) + "\n";
  } else if (ext == ".json") {
    // Printed by hand so that every coordinate keeps 17 significant digits.
    s = "{\n  \"points\": [";
    for (size_t i = 0; i < n; ++i) s += (i ? ",\n    [" : "\n    [") + exact(points[i][0]) + ", " + exact(points[i][1]) + "]";
    s += "\n  ]";
    if (!scalars.empty()) {
      s += ",\n  \"scalars\": {";
      for (size_t k = 0; k < scalars.size(); ++k) {
        const size_t c = size_t(scalars[k].components);
        DSNAKE_ASSERT(scalars[k].values.size() == n * c, "components per vertex: " + scalars[k].name);
        s += (k ? ",\n    " : "\n    ") + nlohmann::json(scalars[k].name).dump() + ": [";
        auto number = [](double v) { return std::isfinite(v) ? exact(v) : std::string("null"); };
        for (size_t i = 0; i < n; ++i) {
          s += i ? ", " : "";
          if (c == 1) {
            s += number(scalars[k].values[i]);
            continue;
          }
          s += "[";
          for (size_t j = 0; j < c; ++j) s += (j ? ", " : "") + number(scalars[k].values[i * c + j]);
          s += "]";
        }
        s += "]";
      }
      s += "\n  }";
    }
    s += "\n}\n";
  } else if (ext == ".vtk") {
    s = vtk_header("dsnake contour") + "POINTS " + std::to_string(n) + " double\n";
    for (const auto& p : points) s += exact(p[0]) + " " + exact(p[1]) + " 0\n";
    s += "LINES 1 " + std::to_string(n + 2) + "\n" + std::to_string(n + 1);
    for (size_t i = 0; i <= n; ++i) s += " " + std::to_string(i % n);
    s += "\n" + vtk_scalars(scalars, n);
  } else {
    throw InputError(path, "", "unknown contour format (expected .txt, .json or .vtk)");
  }
  write_file_atomically(path, s);
}

// 2D: write_contour (connectivity implied); 3D: write_mesh.
template <int D>
void write_shape(const PointList<D>& points, const Connectivity& c, const std::string& path,
                 const std::vector<VertexScalars>& scalars) {
  if constexpr (D == 2) write_contour(points, path, scalars);
  else write_mesh(points, c, path, scalars);
}

template Template<2> read_shape<2>(const std::string&);
template Template<3> read_shape<3>(const std::string&);
template void write_shape<2>(const PointList<2>&, const Connectivity&, const std::string&,
                             const std::vector<VertexScalars>&);
template void write_shape<3>(const PointList<3>&, const Connectivity&, const std::string&,
                             const std::vector<VertexScalars>&);

}  // namespace dsnake
