// INRIMAGE-4 reading and writing (framework/io/inr.cpp): CGAL's demo images (liver.inr.gz and
// the small .inr files), handwritten headers (types, CPU byte orders, origin), round trips and
// bad files.
#include "framework/io/image_io.h"
#include "framework/io/image_io_detail.h"

#include "framework/core/errors.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>
#include <utility>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <unistd.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;  // tests/framework/io_test_support.h

const std::string kCgal = std::string(DSNAKE_SCANS_DIR) + "/cgal/images/";

// An INRIMAGE header of the given KEY=value lines, padded to 256 bytes.
std::string inr_header(const std::string& lines) {
  std::string h = "#INRIMAGE-4#{\n" + lines;
  h += std::string(256 - 4 - h.size(), '\n');
  return h + "##}\n";
}

// The expected numbers below were computed independently of this code, with Python:
//   d = gzip.open('liver.inr.gz').read()[256:]
//   len(d), sum(1 for x in d if x), sum(d), sorted(set(d)), d[x + 438 * (y + 353 * z)]
TEST(Inr, CgalLiverVolume) {
  const std::string path = kCgal + "liver.inr.gz";
  EXPECT_EQ(image_file_dimension(path), 3);
  const Image<3> im = read_image<3>(path);
  EXPECT_EQ(im.size(), (GridIndex<3>{438, 353, 165}));
  // header (zcat liver.inr.gz | head -c 256): VX=0.617188 VY=0.617188 VZ=1.33333, no origin
  EXPECT_EQ(im.spacing(), (Point<3>{0.617188, 0.617188, 1.33333}));
  EXPECT_EQ(im.origin(), (Point<3>{0, 0, 0}));
  int64_t nonzero = 0;
  double sum = 0;
  std::set<float> levels;
  for (float v : im.data()) {
    nonzero += v != 0;
    sum += v;
    levels.insert(v);
  }
  EXPECT_EQ(nonzero, 3492286);
  EXPECT_EQ(sum, 847320240.0);
  EXPECT_EQ(levels, (std::set<float>{0, 84, 85, 127, 255}));
  EXPECT_EQ(im.at({0, 0, 0}), 0);
  EXPECT_EQ(im.at({169, 234, 13}), 127);
  EXPECT_EQ(im.at({174, 238, 16}), 127);
  EXPECT_EQ(im.at({145, 254, 16}), 127);
  EXPECT_EQ(im.at({219, 176, 82}), 255);
}

TEST(Inr, CgalSmallImages) {
  // 2x2x2 unsigned 8-bit, VX=VY=VZ=100 (headers and bytes read with head -c / Python)
  const std::vector<std::pair<std::string, std::vector<float>>> labels = {
      {"12323.inr", {0, 0, 0, 1, 2, 3, 2, 3}},
      {"20012323.inr", {2, 0, 0, 1, 2, 3, 2, 3}},
      {"40420.inr", {4, 0, 4, 4, 2, 2, 0, 0}},
      {"420.inr", {4, 4, 4, 4, 2, 2, 0, 0}}};
  for (const auto& [name, want] : labels) {
    SCOPED_TRACE(name);
    const Image<3> im = read_image<3>(kCgal + name);
    EXPECT_EQ(im.size(), (GridIndex<3>{2, 2, 2}));
    EXPECT_EQ(im.spacing(), (Point<3>{100, 100, 100}));
    EXPECT_EQ(im.data(), want);
  }
  // float 32 bits, a 240-byte header (not a multiple of 256: the data follows "##}\n")
  const Image<3> s = read_image<3>(kCgal + "small-scalar.inr");
  EXPECT_EQ(s.data(), (std::vector<float>{6, -2, -1, 3, -3, 1, -1, -1.4f}));
  const Image<3> skull = read_image<3>(kCgal + "skull_2.9.inr");
  EXPECT_EQ(skull.size(), (GridIndex<3>{64, 64, 64}));
  EXPECT_EQ(skull.spacing(), (Point<3>{3.943050, 3.943050, 3.650790}));
  double sum = 0;
  for (float v : skull.data()) sum += v;
  EXPECT_NEAR(sum, 156293.70635930548, 1e-6);  // Python: sum(struct.unpack('<262144f', data))
  EXPECT_FLOAT_EQ(skull[0], 1.6116002976573895e-10f);
}

TEST(Inr, TypesByteOrdersOriginAnd2D) {
  const std::string dir = fresh_dir();
  std::string be;
  for (int16_t v : {int16_t(-300), int16_t(2), int16_t(32767), int16_t(-1)}) {
    be += char((uint16_t(v) >> 8) & 0xff);
    be += char(uint16_t(v) & 0xff);
  }
  write_file(dir + "/be.inr", inr_header("XDIM=2\nYDIM=2\nZDIM=1\nVDIM=1\nTYPE=signed fixed\nPIXSIZE=16 bits\n"
                                         "CPU=sun\nVX=0.5\nVY=2\nVZ=1\nXO=-3\nYO=4.5\nZO=0\n") + be);
  EXPECT_EQ(image_file_dimension(dir + "/be.inr"), 2);
  const Image<2> im = read_image<2>(dir + "/be.inr");
  EXPECT_EQ(im.data(), (std::vector<float>{-300, 2, 32767, -1}));
  EXPECT_EQ(im.spacing(), (Point<2>{0.5, 2}));
  EXPECT_EQ(im.origin(), (Point<2>{-3, 4.5}));
  const double d[2] = {0.1, -7.25};
  write_file(dir + "/f64.inr", inr_header("XDIM=2\nYDIM=1\nZDIM=1\nTYPE=float\nPIXSIZE=64 bits\nCPU=pc\n") +
                                   std::string(reinterpret_cast<const char*>(d), 16));
  EXPECT_EQ(detail::read_inr(dir + "/f64.inr").values, (std::vector<float>{0.1f, -7.25f}));  // rounded once
}

TEST(Inr, RoundTrips) {
  const std::string dir = fresh_dir();
  Grid<3> g;
  g.size = {4, 3, 2};
  g.spacing = {0.5, 1.25, 3};
  g.origin = {-1.5, 2, 8.125};
  Image<3> e(g);
  for (int64_t i = 0; i < e.num_voxels(); ++i) e[i] = float(std::sin(double(i)) * 50);
  for (const char* name : {"v.inr", "v.inr.gz"}) {
    SCOPED_TRACE(name);
    write_image<3>(e, dir + "/" + name);
    const Image<3> r = read_image<3>(dir + "/" + name);
    EXPECT_TRUE(r.grid().same_geometry(e.grid(), 0));
    EXPECT_EQ(r.data(), e.data());
  }
  std::ifstream in(dir + "/v.inr.gz", std::ios::binary);
  EXPECT_EQ(in.get(), 0x1f);  // gzipped
  EXPECT_EQ(fs::file_size(dir + "/v.inr"), 256u + 24u * 4u);
  Grid<2> g2;
  g2.size = {3, 2};
  g2.spacing = {2, 0.25};
  g2.origin = {1, 1};
  VectorField<2> f(g2);
  for (int64_t i = 0; i < f.num_voxels(); ++i) f[i] = {double(i), -2.0 * double(i)};
  write_vector_field<2>(f, dir + "/f.inr");
  const VectorField<2> r = read_vector_field<2>(dir + "/f.inr");
  EXPECT_TRUE(r.grid().same_geometry(g2, 0));
  for (int64_t i = 0; i < f.num_voxels(); ++i) EXPECT_EQ(r[i], std::as_const(f)[i]);
}

void expect_bad(const std::string& path, const std::string& field, const std::string& words = "") {
  expect_bad_file([](const std::string& p) { read_image<3>(p); }, path, field, words);
}

TEST(Inr, BadFilesNameTheFileAndTheKey) {
  const std::string dir = fresh_dir();
  const std::string ok = "XDIM=2\nYDIM=2\nZDIM=2\nTYPE=unsigned fixed\nPIXSIZE=8 bits\nCPU=decm\n";
  write_file(dir + "/magic.inr", "#INRIMAGE-5#{\n" + inr_header(ok).substr(14) + std::string(8, '\1'));
  expect_bad(dir + "/magic.inr", "magic");
  write_file(dir + "/trunc.inr", inr_header(ok) + std::string(5, '\1'));
  expect_bad(dir + "/trunc.inr", "XDIM/YDIM/ZDIM", "truncated");
  write_file(dir + "/type.inr", inr_header("XDIM=2\nYDIM=2\nZDIM=2\nTYPE=packed\nPIXSIZE=8 bits\n") + std::string(8, '\1'));
  expect_bad(dir + "/type.inr", "TYPE", "packed");
  write_file(dir + "/pix.inr", inr_header("XDIM=2\nYDIM=2\nZDIM=2\nTYPE=unsigned fixed\nPIXSIZE=12 bits\n") +
                                   std::string(8, '\1'));
  expect_bad(dir + "/pix.inr", "PIXSIZE");
  write_file(dir + "/cpu.inr", inr_header(ok + "CPU=vax\n") + std::string(8, '\1'));
  expect_bad(dir + "/cpu.inr", "CPU", "vax");
  write_file(dir + "/nox.inr", inr_header("YDIM=2\nZDIM=2\nTYPE=unsigned fixed\nPIXSIZE=8 bits\n") + std::string(8, '\1'));
  expect_bad(dir + "/nox.inr", "XDIM", "missing");
  write_file(dir + "/open.inr", "#INRIMAGE-4#{\nXDIM=2\n" + std::string(300, '\n'));
  expect_bad(dir + "/open.inr", "header", "##}");
  write_file(dir + "/vx.inr", inr_header(ok + "VX=abc\n") + std::string(8, '\1'));
  expect_bad(dir + "/vx.inr", "VX", "abc");
  // 8e27 voxels: refused from the header and the file's length, without allocating
  const auto start = std::chrono::steady_clock::now();
  write_file(dir + "/huge.inr", inr_header("XDIM=2000000000\nYDIM=2000000000\nZDIM=2000000000\nTYPE=float\n"
                                           "PIXSIZE=32 bits\n") + std::string(64, '\0'));
  expect_bad(dir + "/huge.inr", "XDIM/YDIM/ZDIM");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
}

}  // namespace
}  // namespace dsnake
