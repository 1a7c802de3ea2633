// Round trips and error reports of framework/mesh_io: meshes in OFF, OBJ, PLY, STL, VTK;
// contours in text, JSON, VTK; open, non-manifold, empty and inward-oriented input.
#include "framework/io/mesh_io.h"

#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <unistd.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;  // tests/framework/io_test_support.h

struct TestMesh {
  PointList<3> points;
  std::vector<Triangle> triangles;
};

// Regular icosahedron, shifted off the origin, every face oriented outward.
TestMesh icosahedron() {
  const double t = (1 + std::sqrt(5.0)) / 2;
  TestMesh m;
  m.points = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
              {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& tri : m.triangles) {
    const Point<3> a = m.points[tri[0]], b = m.points[tri[1]], c = m.points[tri[2]];
    if ((b - a).cross(c - a).dot(a + b + c) < 0) std::swap(tri[1], tri[2]);
  }
  const Point<3> shift(0.1, -2.3, 7.77);
  for (auto& p : m.points) p = p * 1.37 + shift;
  return m;
}

double volume(const TestMesh& m) {
  return signed_measure<3>(m.points, Connectivity::mesh(int(m.points.size()), m.triangles));
}

void write(const TestMesh& m, const std::string& path, const std::vector<VertexScalars>& scalars = {}) {
  write_mesh(m.points, Connectivity::mesh(int(m.points.size()), m.triangles), path, scalars);
}

TEST(MeshIo, IcosahedronRoundTripInEveryFormat) {
  const std::string dir = fresh_dir();
  const TestMesh m = icosahedron();
  const double v0 = volume(m);
  ASSERT_GT(v0, 0);
  for (const std::string ext : {".off", ".obj", ".ply", ".stl", ".vtk"}) {
    SCOPED_TRACE(ext);
    const std::string path = dir + "/ico" + ext;
    write(m, path);
    const Template<3> t = read_mesh_template(path);
    ASSERT_EQ(t.num_vertices(), 12);
    EXPECT_EQ(t.connectivity.triangles().size(), 20u);
    EXPECT_EQ(t.connectivity.closed_manifold_problem(), "");
    const double v = signed_measure<3>(t.positions, t.connectivity);
    if (ext == ".stl" || ext == ".ply") {  // OpenMesh: float32 coordinates
      EXPECT_NEAR(v, v0, 1e-6 * v0);
      if (ext == ".ply") {  // ids kept (STL: vertices in order of first appearance)
        for (int i = 0; i < 12; ++i) EXPECT_LT((t.positions[i] - m.points[i]).norm(), 1e-6) << i;
      }
    } else {  // text with 17 digits: exact, ids kept
      EXPECT_NEAR(v, v0, 1e-9 * v0);
      EXPECT_EQ(t.positions, m.points);
    }
    EXPECT_EQ(read_shape<3>(path).num_vertices(), 12);
  }
  // No temporary file is left behind.
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 5);
}

TEST(MeshIo, OpenMeshIsReportedWithTheBoundaryEdge) {
  const std::string dir = fresh_dir();
  TestMesh m = icosahedron();
  m.triangles.pop_back();
  for (const std::string ext : {".off", ".obj", ".vtk", ".ply"}) {
    SCOPED_TRACE(ext);
    write(m, dir + "/open" + ext);
    const InputError e = expect_input_error([&] { read_mesh_template(dir + "/open" + ext); });
    EXPECT_EQ(e.file(), dir + "/open" + ext);
    EXPECT_TRUE(e.where().starts_with("edge (")) << e.what();
    EXPECT_TRUE(contains(e.message(), "not closed")) << e.what();
  }
}

TEST(MeshIo, NonManifoldMeshIsReportedWithTheElement) {
  const std::string dir = fresh_dir();
  // Two tetrahedra sharing vertex 0 only.
  write_file(dir + "/bowtie.off",
             "OFF\n7 8 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n-1 0 0\n0 -1 0\n0 0 -1\n"
             "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 0 5 4\n3 0 4 6\n3 0 6 5\n3 4 5 6\n");
  InputError e = expect_input_error([&] { read_mesh_template(dir + "/bowtie.off"); });
  EXPECT_EQ(e.file(), dir + "/bowtie.off");
  EXPECT_EQ(e.where(), "vertex 0") << e.what();
  EXPECT_TRUE(contains(e.message(), "non-manifold")) << e.what();

  // Three triangles on edge (0, 1): a tetrahedron plus a fin.
  write_file(dir + "/fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0 -1 -1\n"
                               "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 2 5\n");
  e = expect_input_error([&] { read_mesh_template(dir + "/fin.obj"); });
  EXPECT_EQ(e.file(), dir + "/fin.obj");
  EXPECT_EQ(e.where(), "edge (0, 1)") << e.what();

  // Through OpenMesh (PLY), which drops the faces it cannot add: still an InputError.
  write_file(dir + "/bowtie.ply",
             "ply\nformat ascii 1.0\nelement vertex 7\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 8\nproperty list uchar int vertex_indices\nend_header\n"
             "0 0 0\n1 0 0\n0 1 0\n0 0 1\n-1 0 0\n0 -1 0\n0 0 -1\n"
             "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 0 5 4\n3 0 4 6\n3 0 6 5\n3 4 5 6\n");
  e = expect_input_error([&] { read_mesh_template(dir + "/bowtie.ply"); });
  EXPECT_EQ(e.file(), dir + "/bowtie.ply");
  EXPECT_FALSE(e.where().empty()) << e.what();
}

// A binary PLY face whose list count is negative or beyond the file (OpenMesh allocated and read
// on for minutes), a float list count and float vertex indices are refused before OpenMesh reads.
TEST(MeshIo, BinaryPlyListCountsAndIndexTypesAreChecked) {
  const std::string dir = fresh_dir();
  auto ply = [&](const std::string& list, const std::string& face) {
    std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list " + list + " vertex_indices\nend_header\n";
    s += std::string(3 * 3 * 4, '\0');
    return s + face;
  };
  auto int32 = [](int32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  const std::string indices = int32(0) + int32(1) + int32(2);
  const std::vector<std::array<std::string, 3>> cases = {
      {ply("int int", int32(-5) + indices), "element face", "list of -5 items"},
      {ply("int int", int32(2147483647) + indices), "element face", "list of 2147483647 items"},
      {ply("uchar int", std::string(1, '\3') + int32(0)), "element face", "list of 3 items"},
      {ply("int int", "").substr(0, ply("int int", "").size() - 16), "element vertex", "the file ends"},
      {ply("float int", indices + indices), "header line 8", "integer types"},
      {ply("uchar float", std::string(1, '\3') + indices), "header line 8", "integer types"},
  };
  for (const auto& [text, where, words] : cases) {
    SCOPED_TRACE(words);
    write_file(dir + "/bad.ply", text);
    const InputError e = expect_input_error([&] { read_mesh_template(dir + "/bad.ply"); });
    EXPECT_EQ(e.file(), dir + "/bad.ply");
    EXPECT_EQ(e.where(), where) << e.what();
    EXPECT_TRUE(contains(e.message(), words)) << e.what();
  }
}

// A PLY face that refers to a vertex the file does not have is refused naming the face, the index
// and the vertex count (OpenMesh dropped the face, which was reported as a mesh not closed).
TEST(MeshIo, PlyFaceWithAVertexIndexOutOfRangeIsNamed) {
  const std::string dir = fresh_dir();
  const std::string header = "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
  write_file(dir + "/ascii.ply", "ply\nformat ascii 1.0\n" + header + "0 0 0\n1 0 0\n0 1 0\n0 0 1\n" +
                                     "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 7\n");
  auto int32 = [](int32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  std::string binary = "ply\nformat binary_little_endian 1.0\n" + header + std::string(4 * 3 * 4, '\0');
  for (const auto& face : std::vector<std::array<int32_t, 3>>{{0, 2, 1}, {0, -1, 3}, {0, 3, 2}, {1, 2, 3}})
    binary += std::string(1, '\3') + int32(face[0]) + int32(face[1]) + int32(face[2]);
  write_file(dir + "/binary.ply", binary);
  const std::vector<std::array<std::string, 3>> cases = {{"ascii.ply", "face 3", "refers to vertex 7 of 4 vertices"},
                                                         {"binary.ply", "face 1", "refers to vertex -1 of 4 vertices"}};
  for (const auto& [name, where, words] : cases) {
    SCOPED_TRACE(name);
    expect_bad_file([](const std::string& p) { read_mesh_template(p); }, dir + "/" + name, where, words);
  }
}

// A VTK cell's point index that is negative, fractional or past the points is named as such (a
// negative or fractional one was reported as "expected a count").
TEST(MeshIo, VtkCellWithABadPointIndexIsNamed) {
  const std::string dir = fresh_dir();
  const std::string head = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 4 double\n"
                           "0 0 0\n1 0 0\n0 1 0\n0 0 1\nPOLYGONS 4 16\n3 0 2 1\n3 0 1 3\n3 0 3 2\n";
  const std::vector<std::array<std::string, 2>> cases = {{"3 1 -2 3\n", "cell 3: '-2' is not a point index"},
                                                         {"3 1 2.5 3\n", "cell 3: '2.5' is not a point index"},
                                                         {"3 1 2 9\n", "cell 3 refers to point 9, of 4 points"}};
  for (const auto& [cell, words] : cases) {
    SCOPED_TRACE(cell);
    write_file(dir + "/bad.vtk", head + cell);
    expect_bad_file([](const std::string& p) { read_mesh_template(p); }, dir + "/bad.vtk", "POLYGONS", words);
  }
  write_file(dir + "/good.vtk", head + "3 1 2 3\n");
  EXPECT_EQ(read_mesh_template(dir + "/good.vtk").positions.size(), 4u);
}

// An STL vertex with a coordinate that is not a finite number is refused naming its facet and
// vertex, in ASCII and binary files (OpenMesh, merging vertices by their coordinates, made another
// mesh of them, refused as not closed or read as a wrong closed one).
TEST(MeshIo, StlVertexWithANonFiniteCoordinateIsNamed) {
  const std::string dir = fresh_dir();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Point<3>> corners = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, nan}};
  const std::vector<std::array<int, 3>> facets = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  std::string ascii = "solid t\n", binary = std::string(80, '\0');
  const uint32_t count = 4;
  binary += std::string(reinterpret_cast<const char*>(&count), 4);
  for (const auto& f : facets) {
    ascii += "facet normal 0 0 0\nouter loop\n";
    binary += std::string(12, '\0');
    for (int v : f) {
      std::ostringstream line;
      line << "vertex " << corners[v][0] << " " << corners[v][1] << " " << corners[v][2] << "\n";
      ascii += line.str();
      for (int k = 0; k < 3; ++k) {
        const float x = float(corners[v][k]);
        binary += std::string(reinterpret_cast<const char*>(&x), 4);
      }
    }
    ascii += "endloop\nendfacet\n";
    binary += std::string(2, '\0');
  }
  write_file(dir + "/ascii.stl", ascii + "endsolid t\n");
  write_file(dir + "/binary.stl", binary);
  for (const std::string name : {"ascii.stl", "binary.stl"}) {
    expect_bad_file([](const std::string& p) { read_mesh_template(p); }, dir + "/" + name, "facet 1", "vertex 2 has a coordinate that is not a finite number");
  }
}

TEST(MeshIo, EmptyFileIsAnEmptyTemplate) {
  const std::string dir = fresh_dir();
  for (const std::string name : {"/e.off", "/e.obj", "/e.vtk"}) {
    write_file(dir + name, "");
    const InputError e = expect_input_error([&] { read_mesh_template(dir + name); });
    EXPECT_EQ(e.file(), dir + name);
    EXPECT_EQ(e.message(), "empty template");
  }
  write_file(dir + "/zero.off", "OFF\n0 0 0\n");
  EXPECT_EQ(expect_input_error([&] { read_mesh_template(dir + "/zero.off"); }).message(), "empty template");
  const InputError e = expect_input_error([&] { read_mesh_template(dir + "/missing.ply"); });
  EXPECT_TRUE(contains(e.message(), "not found"));
}

TEST(MeshIo, InwardMeshIsFlippedKeepingIds) {
  const std::string dir = fresh_dir();
  TestMesh m = icosahedron();
  const double v0 = volume(m);
  for (auto& t : m.triangles) std::swap(t[0], t[1]);
  ASSERT_LT(volume(m), 0);
  write(m, dir + "/in.off");
  const Template<3> t = read_mesh_template(dir + "/in.off");
  EXPECT_EQ(t.positions, m.points);
  EXPECT_NEAR(signed_measure<3>(t.positions, t.connectivity), v0, 1e-12 * v0);
  EXPECT_EQ(t.connectivity.closed_manifold_problem(), "");
}

// An inward mesh and a mesh of two surfaces are read with one warning line each, and
// every surface is turned outward on its own (a one-sign flip of the whole mesh would leave the
// second surface inward).
TEST(MeshIo, TwoSurfacesOneInwardAreEachTurnedOutwardWithWarnings) {
  const std::string dir = fresh_dir();
  const TestMesh a = icosahedron();
  TestMesh two = a;
  const int n = int(a.points.size());
  for (const auto& p : a.points) two.points.push_back(p + Point<3>(10, 0, 0));
  for (auto t : a.triangles) {
    std::swap(t[0], t[1]);  // the second surface inward
    two.triangles.push_back({t[0] + n, t[1] + n, t[2] + n});
  }
  write(two, dir + "/two.off");
  testing::internal::CaptureStderr();
  const Template<3> t = read_mesh_template(dir + "/two.off");
  const std::string warnings = testing::internal::GetCapturedStderr();
  EXPECT_TRUE(contains(warnings, dir + "/two.off: the mesh has 2 separate surfaces (12, 12 vertices)")) << warnings;
  EXPECT_TRUE(contains(warnings, "some surfaces' triangles face inward")) << warnings;
  EXPECT_EQ(std::count(warnings.begin(), warnings.end(), '\n'), 2) << warnings;
  EXPECT_EQ(t.positions, two.points);
  const auto& tris = t.connectivity.triangles();
  ASSERT_EQ(tris.size(), two.triangles.size());
  std::vector<Triangle> first(tris.begin(), tris.begin() + a.triangles.size());
  std::vector<Triangle> second;
  for (size_t i = a.triangles.size(); i < tris.size(); ++i) second.push_back({tris[i][0] - n, tris[i][1] - n, tris[i][2] - n});
  const double v0 = volume(a);
  PointList<3> shifted;
  for (const auto& p : a.points) shifted.push_back(p + Point<3>(10, 0, 0));
  EXPECT_NEAR(signed_measure<3>(a.points, Connectivity::mesh(n, first)), v0, 1e-12 * v0);
  EXPECT_NEAR(signed_measure<3>(shifted, Connectivity::mesh(n, second)), v0, 1e-9 * v0);
  // An outward single surface: no line at all.
  write(a, dir + "/one.off");
  testing::internal::CaptureStderr();
  read_mesh_template(dir + "/one.off");
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

TEST(MeshIo, ReadsHandWrittenFilesWithQuadsAndTextureIndices) {
  const std::string dir = fresh_dir();
  // A unit cube of quads, with comments, texture/normal references and negative indices.
  write_file(dir + "/cube.obj",
             "# cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\nvn 0 0 1\n"
             "f 1/1/1 4/1/1 3/1/1 2/1/1\nf 5//1 6//1 7//1 8//1\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf -8 -4 -1 -5\n");
  const Template<3> t = read_mesh_template(dir + "/cube.obj");
  EXPECT_EQ(t.connectivity.triangles().size(), 12u);
  EXPECT_NEAR(signed_measure<3>(t.positions, t.connectivity), 1.0, 1e-12);
  write_file(dir + "/cube.off", "OFF 8 6 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
                                "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n");
  EXPECT_NEAR(signed_measure<3>(read_mesh_template(dir + "/cube.off").positions,
                                read_mesh_template(dir + "/cube.off").connectivity), 1.0, 1e-12);
}

TEST(MeshIo, VtkMeshCarriesScalarBlocks) {
  const std::string dir = fresh_dir(), path = dir + "/s.vtk";
  const TestMesh m = icosahedron();
  std::vector<double> ids(12), disp(12);
  for (int i = 0; i < 12; ++i) ids[i] = i, disp[i] = 0.1 * i;
  write(m, path, {{"template_id", ids}, {"displacement", disp}});
  const std::string text = read_file(path);
  EXPECT_TRUE(text.starts_with("# vtk DataFile Version 3.0\n"));
  EXPECT_TRUE(contains(text, "POINT_DATA 12\nSCALARS template_id double 1\nLOOKUP_TABLE default\n0\n1\n"));
  EXPECT_TRUE(contains(text, "SCALARS displacement double 1\nLOOKUP_TABLE default\n0\n0.10000000000000001\n"));
  EXPECT_EQ(read_mesh_template(path).positions, m.points);
}

TEST(MeshIo, UnknownExtensionNamesTheFile) {
  const std::string dir = fresh_dir();
  const TestMesh m = icosahedron();
  InputError e = expect_input_error([&] { write(m, dir + "/m.xyz"); });
  EXPECT_EQ(e.file(), dir + "/m.xyz");
  e = expect_input_error([&] { read_mesh_template(dir + "/m.xyz"); });
  EXPECT_EQ(e.file(), dir + "/m.xyz");
  e = expect_input_error([&] { write_contour({{0, 0}, {1, 0}, {0, 1}}, dir + "/c.off"); });
  EXPECT_EQ(e.file(), dir + "/c.off");
}

// An irregular star with coordinates that need all 17 digits.
PointList<2> star() {
  PointList<2> p;
  for (int i = 0; i < 10; ++i) {
    const double a = 2 * M_PI * i / 10, r = i % 2 ? 1.0 / 3.0 : 2.0 + 1e-13 * i;
    p.emplace_back(r * std::cos(a) + 0.1, r * std::sin(a) - 1e-7);
  }
  return p;
}

TEST(ContourIo, RoundTripIsExactInEveryFormat) {
  const std::string dir = fresh_dir();
  const PointList<2> p = star();
  std::vector<double> s(p.size());
  for (size_t i = 0; i < s.size(); ++i) s[i] = std::sqrt(double(i));
  for (const std::string ext : {".txt", ".json", ".vtk"}) {
    SCOPED_TRACE(ext);
    write_contour(p, dir + "/c" + ext, {{"arc length", s}});
    const Template<2> t = read_contour_template(dir + "/c" + ext);
    EXPECT_EQ(t.positions, p);
    EXPECT_EQ(t.connectivity.num_vertices(), 10);
    EXPECT_TRUE(t.connectivity.is_polygon());
    write_shape<2>(p, Connectivity::polygon(10), dir + "/d" + ext);
    EXPECT_EQ(read_shape<2>(dir + "/d" + ext).positions, p);
  }
  const std::string vtk = read_file(dir + "/c.vtk");
  EXPECT_TRUE(contains(vtk, "LINES 1 12\n11 0 1 2 3 4 5 6 7 8 9 0\n")) << vtk;
  EXPECT_TRUE(contains(vtk, "POINT_DATA 10\nSCALARS arc_length double 1\nLOOKUP_TABLE default\n0\n1\n1.4142135623730951\n"));
  EXPECT_TRUE(contains(read_file(dir + "/c.json"), "\"arc length\": [0, 1, 1.4142135623730951"));
}

TEST(ContourIo, OrientationIsKept) {
  const std::string dir = fresh_dir();
  PointList<2> p = star();
  std::reverse(p.begin(), p.end());  // clockwise
  write_contour(p, dir + "/cw.txt");
  const Template<2> t = read_contour_template(dir + "/cw.txt");
  EXPECT_EQ(t.positions, p);
  EXPECT_LT(signed_measure<2>(t.positions, t.connectivity), 0);
}

TEST(ContourIo, TextSkipsCommentsAndNamesTheBadLine) {
  const std::string dir = fresh_dir();
  write_file(dir + "/ok.txt", "# a triangle\n\n0 0\n  1 0  # right\n0 1\n\n");
  EXPECT_EQ(read_contour_template(dir + "/ok.txt").num_vertices(), 3);
  write_file(dir + "/bad.txt", "# header\n0 0\n\n1 0\n0 1\n# more\n0.5 oops\n");
  const InputError e = expect_input_error([&] { read_contour_template(dir + "/bad.txt"); });
  EXPECT_EQ(e.file(), dir + "/bad.txt");
  EXPECT_EQ(e.where(), "line 7");
  EXPECT_EQ(e.message(), "expected two numbers");
}

TEST(ContourIo, InvalidContoursAreInputErrors) {
  const std::string dir = fresh_dir();
  write_file(dir + "/two.txt", "0 0\n1 0\n");
  EXPECT_TRUE(contains(expect_input_error([&] { read_contour_template(dir + "/two.txt"); }).message(), "at least 3"));
  write_file(dir + "/dup.txt", "0 0\n1 0\n1 0\n0 1\n");
  EXPECT_EQ(expect_input_error([&] { read_contour_template(dir + "/dup.txt"); }).where(), "vertex 1");
  write_file(dir + "/nan.txt", "0 0\n1 nan\n0 1\n");
  EXPECT_EQ(expect_input_error([&] { read_contour_template(dir + "/nan.txt"); }).where(), "vertex 1");
  write_file(dir + "/k.json", "{\"points\": [[0, 0], [1, 0], [0, 1]], \"colour\": 3}");
  EXPECT_EQ(expect_input_error([&] { read_contour_template(dir + "/k.json"); }).where(), "colour");
  write_file(dir + "/p.json", "{\"points\": [[0, 0], [1, 0, 2], [0, 1]]}");
  EXPECT_EQ(expect_input_error([&] { read_contour_template(dir + "/p.json"); }).where(), "points[1]");
  write_file(dir + "/l.json", "{\"points\": [[0, 0], [1, 0], [0, 1]], \"landmarks\": {\"tip\": 3}}");
  EXPECT_EQ(expect_input_error([&] { read_contour_template(dir + "/l.json"); }).where(), "landmarks.tip");
  write_file(dir + "/s.json", "{\"points\": [[0, 0], [1, 0]");
  EXPECT_EQ(expect_input_error([&] { read_contour_template(dir + "/s.json"); }).file(), dir + "/s.json");
}

TEST(ContourIo, JsonLandmarksAreRead) {
  const std::string dir = fresh_dir();
  write_file(dir + "/l.json", "{\"points\": [[0, 0], [1, 0], [0, 1]], \"landmarks\": {\"tip\": 2, \"base\": 0}}");
  const Template<2> t = read_contour_template(dir + "/l.json");
  EXPECT_EQ(t.landmarks, (std::map<std::string, int>{{"base", 0}, {"tip", 2}}));
}

}  // namespace
}  // namespace dsnake
