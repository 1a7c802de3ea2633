// NRRD reading and writing (framework/io/nrrd.cpp): ITK's example .nhdr files against their
// MetaImage twins, handwritten headers (types, byte orders, RAS -> LPS, vector axes, the older
// spacings/axis mins), round trips (2D, 3D, raw, gzip, attached and detached) and bad files.
#include "framework/io/image_io.h"
#include "framework/io/image_io_detail.h"

#include "framework/core/errors.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <unistd.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;  // tests/framework/io_test_support.h

const std::string kItk = std::string(DSNAKE_SCANS_DIR) + "/itk/";

// The bytes of values of type T in big-endian order.
template <class T>
std::string big_endian(const std::vector<T>& values) {
  std::string out;
  for (T v : values) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    std::reverse(b, b + sizeof(T));
    out.append(b, sizeof(T));
  }
  return out;
}

template <class T>
std::string little_endian(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

// gzip of bytes, made with zlib's gz writer (not the code under test).
std::string gzip_file_bytes(const std::string& dir, const std::string& bytes) {
  const std::string tmp = dir + "/tmp.gz";
  gzFile f = gzopen(tmp.c_str(), "wb");
  gzwrite(f, bytes.data(), unsigned(bytes.size()));
  gzclose(f);
  std::ifstream in(tmp, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A 3D volume with anisotropic spacing, an offset origin and non-round values.
Image<3> test_volume() {
  Grid<3> g;
  g.size = {5, 4, 3};
  g.spacing = {0.5, 1.25, 2.0};
  g.origin = {-3.5, 10.25, 7.0};
  Image<3> im(g);
  for (int64_t i = 0; i < im.num_voxels(); ++i) im[i] = float(std::sin(0.37 * double(i)) * 100.0 + 0.125);
  return im;
}

Image<2> test_image() {
  Grid<2> g;
  g.size = {7, 3};
  g.spacing = {0.75, 1.5};
  g.origin = {2.5, -4.0};
  Image<2> im(g);
  for (int64_t i = 0; i < im.num_voxels(); ++i) im[i] = float(std::cos(0.91 * double(i)) * 17.0 - 3.0);
  return im;
}

template <int D>
void expect_identical(const Image<D>& got, const Image<D>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (int a = 0; a < D; ++a) {
    EXPECT_EQ(got.spacing()[a], want.spacing()[a]);
    EXPECT_EQ(got.origin()[a], want.origin()[a]);
  }
  for (int64_t i = 0; i < want.num_voxels(); ++i) ASSERT_EQ(got[i], want[i]) << "voxel " << i;
}

// ---------------------------------------------------------------- ITK's files

TEST(Nrrd, ItkNhdrGivesTheVoxelsSpacingAndOriginOfTheMetaImage) {
  const Image<2> nrrd = read_image<2>(kItk + "BrainProtonDensitySliceBorder20.nhdr");
  const Image<2> meta = read_image<2>(kItk + "BrainProtonDensitySliceBorder20.mhd");
  EXPECT_EQ(nrrd.size(), (GridIndex<2>{221, 257}));
  expect_identical(nrrd, meta);
  double sum = 0;
  for (float v : nrrd.data()) sum += v;
  EXPECT_GT(sum, 1e6);  // a real image, not zeros
  EXPECT_EQ(image_file_dimension(kItk + "BrainProtonDensitySliceBorder20.nhdr"), 2);
  expect_identical(read_image<2>(kItk + "BrainProtonDensitySliceShifted13x17y.nhdr"),
                   read_image<2>(kItk + "BrainProtonDensitySliceShifted13x17y.mhd"));
}

TEST(Nrrd, ItkRotatedNhdrGivesTheDirectionOfTheMetaImage) {
  for (const char* stem : {"BrainProtonDensitySliceBorder20DirectionPlus30", "BrainT1SliceBorder20DirectionPlus30"}) {
    SCOPED_TRACE(stem);
    const detail::RawVolume nrrd = detail::read_nrrd(kItk + stem + ".nhdr");
    const detail::RawVolume meta = detail::read_meta(kItk + stem + ".mhd");
    ASSERT_EQ(nrrd.ndims, 2);
    // +30 degrees: index axis 0 along (cos 30, sin 30), axis 1 along (-sin 30, cos 30)
    EXPECT_NEAR(nrrd.axes[0][0], std::cos(M_PI / 6), 1e-6);
    EXPECT_NEAR(nrrd.axes[0][1], 0.5, 1e-6);
    EXPECT_NEAR(nrrd.axes[1][0], -0.5, 1e-6);
    for (int a = 0; a < 2; ++a)
      for (int k = 0; k < 2; ++k) EXPECT_NEAR(nrrd.axes[a][k], meta.axes[a][k], 1e-6) << a << "," << k;
    for (int a = 0; a < 2; ++a) EXPECT_NEAR(nrrd.spacing[a], meta.spacing[a], 1e-6);
    ASSERT_EQ(nrrd.values.size(), meta.values.size());
    EXPECT_EQ(nrrd.values, meta.values);
  }
}

// ---------------------------------------------------------------- handwritten headers

TEST(Nrrd, TypesAndByteOrdersDecode) {
  const std::string dir = fresh_dir();
  const std::string head = "NRRD0004\ndimension: 2\nsizes: 2 2\nencoding: raw\n";
  write_file(dir + "/i8.nrrd", head + "type: signed char\n\n" + little_endian<int8_t>({-128, -1, 0, 127}));
  write_file(dir + "/u16.nrrd", head + "type: unsigned short\nendian: big\n\n" + big_endian<uint16_t>({1, 256, 65535, 513}));
  write_file(dir + "/i32.nrrd", head + "type: int32\nendian: little\n\n" + little_endian<int32_t>({-70000, 5, 0, 2000000000}));
  write_file(dir + "/u32.nhdr", head + "type: uint\nendian: big\ndata file: u32.bin\n");
  write_file(dir + "/u32.bin", big_endian<uint32_t>({4000000000u, 1, 2, 3}));
  write_file(dir + "/f64.nrrd", head + "type: double\nendian: big\n\n" + big_endian<double>({0.1, -2.5, 1e300, 7}));
  const std::vector<std::pair<std::string, std::vector<float>>> cases = {
      {"i8.nrrd", {-128, -1, 0, 127}},
      {"u16.nrrd", {1, 256, 65535, 513}},
      {"i32.nrrd", {-70000, 5, 0, 2e9f}},
      {"u32.nhdr", {4e9f, 1, 2, 3}},
      {"f64.nrrd", {0.1f, -2.5f, float(1e300), 7}}};
  for (const auto& [name, want] : cases) {
    SCOPED_TRACE(name);
    if (name == "f64.nrrd") {
      const detail::RawVolume v = detail::read_nrrd(dir + "/" + name);
      // Rounded once to float, as an Image holds them; 1e300 is beyond float's range.
      EXPECT_EQ(v.values, (std::vector<float>{0.1f, -2.5f, INFINITY, 7}));
      // As an image it is refused, naming the voxel (not silently infinite).
      try {
        read_image<2>(dir + "/" + name);
        ADD_FAILURE() << "read a value beyond float's range";
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("voxel (0, 1): value is infinite or beyond float's range"),
                  std::string::npos) << e.what();
      }
      continue;
    }
    const Image<2> im = read_image<2>(dir + "/" + name);
    EXPECT_EQ(im.data(), want);
  }
}

// The 64-bit integer types under each of the NRRD spec's names, in either byte order, raw and
// gzip: each value its nearest float, also where rounding through double would miss it
// (2^60 + 2^36 + 1 is nearer 2^60 + 2^37 than 2^60, its double's float).
TEST(Nrrd, SixtyFourBitIntegerTypesDecode) {
  const std::string dir = fresh_dir();
  const int64_t tricky = (int64_t(1) << 60) + (int64_t(1) << 36) + 1;
  const std::vector<int64_t> s = {tricky, -3'000'000'000, std::numeric_limits<int64_t>::min(), 7};
  const std::vector<uint64_t> u = {uint64_t(tricky), (uint64_t(1) << 63) + (uint64_t(1) << 40),
                                   std::numeric_limits<uint64_t>::max(), 7};
  int n = 0;
  for (const bool is_signed : {true, false}) {
    const std::vector<std::string> names =
        is_signed ? std::vector<std::string>{"long long", "longlong", "long long int", "signed long long",
                                             "signed long long int", "int64", "int64_t"}
                  : std::vector<std::string>{"unsigned long long", "unsigned long long int", "ulonglong", "uint64",
                                             "uint64_t"};
    for (const std::string& name : names) {
      SCOPED_TRACE(name);
      const bool big = n % 2 == 1, gz = n % 3 == 2;
      ++n;
      const std::string data = is_signed ? (big ? big_endian(s) : little_endian(s)) : (big ? big_endian(u) : little_endian(u));
      const std::string path = dir + "/v" + std::to_string(n) + ".nrrd";
      write_file(path, "NRRD0004\ntype: " + name + "\ndimension: 2\nsizes: 2 2\nendian: " + (big ? "big" : "little") +
                           "\nencoding: " + (gz ? "gzip" : "raw") + "\n\n" + (gz ? gzip_file_bytes(dir, data) : data));
      const Image<2> im = read_image<2>(path);
      for (int i = 0; i < 4; ++i)
        EXPECT_EQ(im[i], is_signed ? static_cast<float>(s[size_t(i)]) : static_cast<float>(u[size_t(i)])) << i;
      EXPECT_EQ(im[0], float(uint64_t(1) << 60) + float(uint64_t(1) << 37));
    }
  }
}

// RAS directions and origin are converted to LPS (x, y negated); the identity RAS grid thus has
// its x and y axes reversed in LPS, and read_image reorders the voxels so every voxel keeps its
// world position.
TEST(Nrrd, RasSpaceIsConvertedToLps) {
  const std::string dir = fresh_dir();
  std::vector<float> data(3 * 2 * 2);
  for (size_t i = 0; i < data.size(); ++i) data[i] = float(i);
  write_file(dir + "/ras.nrrd",
             "NRRD0005\ntype: float\ndimension: 3\nspace: right-anterior-superior\nsizes: 3 2 2\n"
             "space directions: (2,0,0) (0,3,0) (0,0,4)\nspace origin: (10,20,30)\nendian: little\n"
             "encoding: raw\nkinds: domain domain domain\n\n" + little_endian(data));
  const detail::RawVolume raw = detail::read_nrrd(dir + "/ras.nrrd");
  EXPECT_EQ(raw.axes[0], (std::array<double, 3>{-1, 0, 0}));
  EXPECT_EQ(raw.axes[1], (std::array<double, 3>{0, -1, 0}));
  EXPECT_EQ(raw.axes[2], (std::array<double, 3>{0, 0, 1}));
  EXPECT_EQ(raw.origin, (std::array<double, 3>{-10, -20, 30}));
  EXPECT_EQ(raw.spacing, (std::array<double, 3>{2, 3, 4}));
  const Image<3> im = read_image<3>(dir + "/ras.nrrd");
  EXPECT_EQ(im.spacing(), (Point<3>{2, 3, 4}));
  // LPS x of stored voxel i is -10 - 2 i: the smallest, -14, belongs to stored i = 2
  EXPECT_EQ(im.origin(), (Point<3>{-14, -23, 30}));
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x)
        EXPECT_EQ(im.at({x, y, z}), data[(2 - x) + 3 * ((1 - y) + 2 * z)]) << x << y << z;

  // the same grid written as LPS, with LPS directions, reads as the same world image
  write_file(dir + "/lps.nrrd",
             "NRRD0005\ntype: float\ndimension: 3\nspace: LPS\nsizes: 3 2 2\n"
             "space directions: (-2,0,0) (0,-3,0) (0,0,4)\nspace origin: (-10,-20,30)\nendian: little\n"
             "encoding: raw\n\n" + little_endian(data));
  expect_identical(read_image<3>(dir + "/lps.nrrd"), im);
}

TEST(Nrrd, LeadingVectorAxisIsAVectorField) {
  const std::string dir = fresh_dir();
  std::vector<float> data(3 * 2 * 2 * 2);
  for (size_t i = 0; i < data.size(); ++i) data[i] = float(i) * 0.5f;
  write_file(dir + "/v.nrrd",
             "NRRD0004\ntype: float\ndimension: 4\nspace: left-posterior-superior\nsizes: 3 2 2 2\n"
             "space directions: none (1.5,0,0) (0,1,0) (0,0,2)\nkinds: covariant-vector domain domain domain\n"
             "endian: little\nencoding: raw\nspace origin: (1,2,3)\n\n" + little_endian(data));
  const VectorField<3> f = read_vector_field<3>(dir + "/v.nrrd");
  EXPECT_EQ(f.grid().size, (GridIndex<3>{2, 2, 2}));
  EXPECT_EQ(f.grid().spacing, (Point<3>{1.5, 1, 2}));
  EXPECT_EQ(f.grid().origin, (Point<3>{1, 2, 3}));
  for (int64_t i = 0; i < 8; ++i)
    for (int a = 0; a < 3; ++a) EXPECT_EQ(f[i][a], data[size_t(3 * i + a)]);
  EXPECT_EQ(image_file_dimension(dir + "/v.nrrd"), 3);
  // a scalar read of a vector file names the channel field
  const InputError e = expect_input_error([&] { read_image<3>(dir + "/v.nrrd"); });
  EXPECT_EQ(e.where(), "kinds");
}

TEST(Nrrd, SpacingsAndAxisMinsWithoutSpace) {
  const std::string dir = fresh_dir();
  write_file(dir + "/old.nhdr",
             "NRRD0001\n# old style\ntype: uchar\ndimension: 3\nsizes: 2 1 2\nspacings: 0.25 4 1.5\n"
             "axis mins: -1 2 3.5\nencoding: gz\ndatafile: ./old.raw.gz\n");
  write_file(dir + "/old.raw.gz", gzip_file_bytes(dir, std::string("\x01\x02\x03\x04", 4)));
  const Image<3> im = read_image<3>(dir + "/old.nhdr");
  EXPECT_EQ(im.size(), (GridIndex<3>{2, 1, 2}));
  EXPECT_EQ(im.spacing(), (Point<3>{0.25, 4, 1.5}));
  EXPECT_EQ(im.origin(), (Point<3>{-1, 2, 3.5}));
  EXPECT_EQ(im.data(), (std::vector<float>{1, 2, 3, 4}));
}

// A 2D slice in 3D space (dimension 2, space LPS): a one-slice volume whose third axis is the
// slice normal; here the slice is the y-z plane (x axis of the file along world y, y along z).
TEST(Nrrd, SliceIn3DSpaceAndSkips) {
  const std::string dir = fresh_dir();
  write_file(dir + "/slice.nrrd",
             "NRRD0004\ntype: uchar\ndimension: 2\nspace: LPS\nsizes: 3 2\n"
             "space directions: (0,0.5,0) (0,0,2)\nspace origin: (7,1,2)\nencoding: raw\n\n" +
             std::string("\x01\x02\x03\x04\x05\x06", 6));
  const detail::RawVolume v = detail::read_nrrd(dir + "/slice.nrrd");
  EXPECT_EQ(v.ndims, 3);
  EXPECT_EQ(v.effective_dimension(), 2);
  EXPECT_EQ(v.size, (std::array<int64_t, 3>{3, 2, 1}));
  EXPECT_EQ(v.axes[0], (std::array<double, 3>{0, 1, 0}));
  EXPECT_EQ(v.axes[1], (std::array<double, 3>{0, 0, 1}));
  EXPECT_EQ(v.axes[2], (std::array<double, 3>{1, 0, 0}));  // normal: x cross y
  EXPECT_EQ(v.spacing[0], 0.5);
  EXPECT_EQ(v.origin, (std::array<double, 3>{7, 1, 2}));
  EXPECT_EQ(image_file_dimension(dir + "/slice.nrrd"), 2);
  // byte skip -1: the data are the last bytes of the data file; line skip: lines before them
  write_file(dir + "/tail.nhdr", "NRRD0004\ntype: uint16\nendian: little\ndimension: 2\nsizes: 2 1\n"
                                 "encoding: raw\nbyte skip: -1\ndata file: tail.bin\n");
  write_file(dir + "/tail.bin", "some preamble" + little_endian<uint16_t>({300, 7}));
  EXPECT_EQ(read_image<2>(dir + "/tail.nhdr").data(), (std::vector<float>{300, 7}));
  write_file(dir + "/lines.nhdr", "NRRD0004\ntype: uint8\ndimension: 2\nsizes: 2 1\nencoding: raw\n"
                                  "line skip: 2\nbyte skip: 1\ndata file: lines.bin\n");
  write_file(dir + "/lines.bin", "first\nsecond\nx\x09\x0a");
  EXPECT_EQ(read_image<2>(dir + "/lines.nhdr").data(), (std::vector<float>{9, 10}));
  // The same skips with the data attached, after a header longer than the 64 kB read first
  std::string comments;
  for (int i = 0; i < 30; ++i) comments += "# " + std::string(3000, 'c') + "\n";
  write_file(dir + "/lines.nrrd", "NRRD0004\ntype: uint8\ndimension: 2\nsizes: 2 1\nencoding: raw\n" + comments +
                                      "line skip: 2\nbyte skip: 1\n\nfirst\nsecond\nx\x09\x0a");
  EXPECT_EQ(read_image<2>(dir + "/lines.nrrd").data(), (std::vector<float>{9, 10}));
  write_file(dir + "/few_lines.nrrd", "NRRD0004\ntype: uint8\ndimension: 2\nsizes: 2 1\nencoding: raw\n"
                                      "line skip: 4\n\nfirst\nsecond\nx\x09\x0a");
  expect_bad_file([](const std::string& p) { read_image<2>(p); }, dir + "/few_lines.nrrd", "line skip",
                  "fewer lines than skipped");
  // left-anterior-superior: y negated
  write_file(dir + "/las.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nspace: left-anterior-superior\n"
                                "sizes: 1 1 1\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (1,2,3)\n"
                                "encoding: raw\n\n\x05");
  const detail::RawVolume las = detail::read_nrrd(dir + "/las.nrrd");
  EXPECT_EQ(las.axes[1], (std::array<double, 3>{0, -1, 0}));
  EXPECT_EQ(las.origin, (std::array<double, 3>{1, -2, 3}));
}

// ---------------------------------------------------------------- round trips

TEST(Nrrd, RoundTrips3DRawGzipAttachedAndDetached) {
  const std::string dir = fresh_dir();
  const Image<3> e = test_volume();
  for (const char* name : {"a.nrrd", "b.nhdr"})
    for (bool gz : {false, true}) {
      const std::string path = dir + "/" + (gz ? "gz_" : "raw_") + name;
      SCOPED_TRACE(path);
      ImageWriteOptions o;
      o.compress = gz;
      write_image<3>(e, path, o);
      expect_identical(read_image<3>(path), e);
      EXPECT_EQ(image_file_dimension(path), 3);
    }
  EXPECT_TRUE(fs::exists(dir + "/raw_b.raw"));
  EXPECT_TRUE(fs::exists(dir + "/gz_b.raw.gz"));
  // gzip really compressed (the volume is 60 floats; a sine is not all distinct bytes, but the
  // header says gzip and the data must start with the gzip magic)
  std::ifstream in(dir + "/gz_b.raw.gz", std::ios::binary);
  EXPECT_EQ(in.get(), 0x1f);
  EXPECT_EQ(in.get(), 0x8b);
}

TEST(Nrrd, RoundTrips2DAndVectorFields) {
  const std::string dir = fresh_dir();
  const Image<2> e = test_image();
  for (bool gz : {false, true}) {
    ImageWriteOptions o;
    o.compress = gz;
    write_image<2>(e, dir + "/i.nrrd", o);
    expect_identical(read_image<2>(dir + "/i.nrrd"), e);
    EXPECT_EQ(image_file_dimension(dir + "/i.nrrd"), 2);
  }
  VectorField<2> f(e.grid());
  for (int64_t i = 0; i < f.num_voxels(); ++i) f[i] = {double(e[i]), -0.5 * double(i)};
  write_vector_field<2>(f, dir + "/f.nrrd");
  const VectorField<2> g = read_vector_field<2>(dir + "/f.nrrd");
  ASSERT_TRUE(g.grid().same_geometry(f.grid(), 0));
  for (int64_t i = 0; i < f.num_voxels(); ++i) {
    EXPECT_EQ(g[i][0], float(f[i][0]));
    EXPECT_EQ(g[i][1], float(f[i][1]));
  }
}

// write_nrrd stores the axes (direction x spacing): a permuted and flipped frame and an
// oblique one come back as written.
TEST(Nrrd, RoundTripKeepsAxes) {
  const std::string dir = fresh_dir();
  detail::RawVolume v;
  v.size = {2, 3, 2};
  v.spacing = {0.5, 2, 3};
  v.origin = {1, -2, 4.5};
  v.axes = {{{0, 1, 0}, {-1, 0, 0}, {0, 0, -1}}};
  for (int i = 0; i < 12; ++i) v.values.push_back(i * 1.5);
  detail::write_nrrd(v, dir + "/p.nrrd", false);
  detail::RawVolume r = detail::read_nrrd(dir + "/p.nrrd");
  EXPECT_EQ(r.axes, v.axes);
  EXPECT_EQ(r.spacing, v.spacing);
  EXPECT_EQ(r.origin, v.origin);
  EXPECT_EQ(r.values, v.values);
  const double c = std::cos(0.3), s = std::sin(0.3);
  v.axes = {{{c, s, 0}, {-s, c, 0}, {0, 0, 1}}};
  detail::write_nrrd(v, dir + "/o.nrrd", true);
  r = detail::read_nrrd(dir + "/o.nrrd");
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(r.spacing[a], v.spacing[a], 1e-14);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.axes[a][k], v.axes[a][k], 1e-14);
  }
  EXPECT_EQ(r.values, v.values);
}

// ---------------------------------------------------------------- bad files

// Each bad file must throw an InputError that names it and the field at fault.
void expect_bad(const std::string& path, const std::string& field, const std::string& words = "") {
  expect_bad_file([](const std::string& p) { read_image<2>(p); }, path, field, words);
}

TEST(Nrrd, BadFilesNameTheFileAndTheField) {
  const std::string dir = fresh_dir();
  const std::string head = "NRRD0004\ntype: uint8\ndimension: 2\n";
  const std::string four(4, '\x07');
  write_file(dir + "/magic.nrrd", "NRRX0004\n" + head.substr(9) + "sizes: 2 2\nencoding: raw\n\n" + four);
  expect_bad(dir + "/magic.nrrd", "magic");
  write_file(dir + "/trunc.nrrd", head + "sizes: 3 2\nencoding: raw\n\n" + four);
  expect_bad(dir + "/trunc.nrrd", "sizes", "6 bytes");
  write_file(dir + "/count.nrrd", head + "sizes: 2 2 2\nencoding: raw\n\n" + four);
  expect_bad(dir + "/count.nrrd", "sizes");
  write_file(dir + "/enc.nrrd", head + "sizes: 2 2\nencoding: bzip2\n\n" + four);
  expect_bad(dir + "/enc.nrrd", "encoding", "bzip2");
  write_file(dir + "/type.nrrd", "NRRD0004\ntype: long\ndimension: 2\nsizes: 1 1\nendian: little\nencoding: raw\n\n" +
                                     std::string(8, '\0'));
  expect_bad(dir + "/type.nrrd", "type", "unsupported type 'long'");
  write_file(dir + "/block.nrrd", "NRRD0004\ntype: block\ndimension: 2\nsizes: 1 1\nencoding: raw\n\n" + four);
  expect_bad(dir + "/block.nrrd", "type");
  write_file(dir + "/endian.nrrd", "NRRD0004\ntype: short\ndimension: 2\nsizes: 2 1\nencoding: raw\n\n" + four);
  expect_bad(dir + "/endian.nrrd", "endian");
  write_file(dir + "/missing.nhdr", head + "sizes: 2 2\nencoding: raw\ndata file: nowhere.raw\n");
  expect_bad(dir + "/missing.nhdr", "data file", "nowhere.raw");
  write_file(dir + "/nodata.nhdr", head + "sizes: 2 2\nencoding: raw\n");
  expect_bad(dir + "/nodata.nhdr", "data file");
  // a detached header naming itself as its data file (it read its own text as voxels)
  write_file(dir + "/self.nhdr", head + "sizes: 2 2\nencoding: raw\ndata file: ./self.nhdr\n");
  expect_bad(dir + "/self.nhdr", "data file", "header itself");
  write_file(dir + "/time.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nspace: left-posterior-superior-time\n"
                                 "sizes: 2 2 1\nencoding: raw\n\n" + four);
  expect_bad(dir + "/time.nrrd", "space", "time");
  write_file(dir + "/gz.nrrd", head + "sizes: 2 2\nencoding: gzip\n\nthis is not gzip data at all");
  expect_bad(dir + "/gz.nrrd", "encoding", "corrupt");
  const std::string gz = gzip_file_bytes(dir, std::string(3, '\x05'));
  write_file(dir + "/gzshort.nrrd", head + "sizes: 2 2\nencoding: gzip\n\n" + gz);
  expect_bad(dir + "/gzshort.nrrd", "sizes", "truncated");
  write_file(dir + "/negative.nrrd", head + "sizes: 2 -2\nencoding: raw\n\n" + four);
  expect_bad(dir + "/negative.nrrd", "sizes");
  write_file(dir + "/nosizes.nrrd", "NRRD0004\ntype: uint8\ndimension: 2\nencoding: raw\n\n" + four);
  expect_bad(dir + "/nosizes.nrrd", "sizes", "missing");
  write_file(dir + "/dir.nrrd", head + "space dimension: 2\nsizes: 2 2\nspace directions: (1,0) (0,0)\n"
                                "encoding: raw\n\n" + four);
  expect_bad(dir + "/dir.nrrd", "space directions");
  // a NaN component, and one whose length overflows, are named as such, not as an axis without length
  write_file(dir + "/dir_nan.nrrd", head + "space dimension: 2\nsizes: 2 2\nspace directions: (nan,0) (0,1)\n"
                                    "encoding: raw\n\n" + four);
  expect_bad(dir + "/dir_nan.nrrd", "space directions", "not a finite number");
  write_file(dir + "/dir_long.nrrd", head + "space dimension: 2\nsizes: 2 2\nspace directions: (1e308,1e308) (0,1)\n"
                                     "encoding: raw\n\n" + four);
  expect_bad(dir + "/dir_long.nrrd", "space directions", "too long");
  write_file(dir + "/line.nrrd", head + "sizes 2 2\nencoding: raw\n\n" + four);
  expect_bad(dir + "/line.nrrd", "header line 4");
  // A colour image is not a volume (its first axis holds the colour, not a position), nor is a
  // slice series in time.
  const std::string eight(8, '\x07');
  write_file(dir + "/rgb.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nkinds: RGB-color domain domain\n"
                                "encoding: raw\n\n" + eight);
  expect_bad(dir + "/rgb.nrrd", "kinds");
  write_file(dir + "/slices_in_time.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\n"
                                           "kinds: domain domain time\nencoding: raw\n\n" + eight);
  expect_bad(dir + "/slices_in_time.nrrd", "kinds", "time");
}

// Sizes of 10^12 and more voxels are refused from the header and the data's length, quickly
// and without allocating them (raw, gzip, and sizes whose product overflows 64 bits).
TEST(Nrrd, AbsurdSizesAreRefusedWithoutAllocating) {
  const std::string dir = fresh_dir();
  const auto start = std::chrono::steady_clock::now();
  write_file(dir + "/huge.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 10000 10000 10000\nendian: little\n"
                                 "encoding: raw\n\n" + std::string(64, '\0'));
  const InputError e1 = expect_input_error([&] { read_image<3>(dir + "/huge.nrrd"); });
  EXPECT_EQ(e1.where(), "sizes");
  write_file(dir + "/hugegz.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 10000 10000 10000\nendian: little\n"
                                   "encoding: gzip\n\n" + gzip_file_bytes(dir, std::string(64, '\0')));
  const InputError e2 = expect_input_error([&] { read_image<3>(dir + "/hugegz.nrrd"); });
  EXPECT_EQ(e2.where(), "sizes");
  write_file(dir + "/overflow.nrrd", "NRRD0004\ntype: double\ndimension: 4\nkinds: vector domain domain domain\n"
                                     "sizes: 3 2147483647 2147483647 2147483647\nendian: little\nencoding: raw\n\n");
  const InputError e3 = expect_input_error([&] { read_vector_field<3>(dir + "/overflow.nrrd"); });
  EXPECT_EQ(e3.where(), "sizes");
  write_file(dir + "/toolarge.nrrd", "NRRD0004\ntype: float\ndimension: 2\nsizes: 99999999999 2\nencoding: raw\n\n");
  const InputError e4 = expect_input_error([&] { read_image<2>(dir + "/toolarge.nrrd"); });
  EXPECT_EQ(e4.where(), "sizes");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 1.0);
}

}  // namespace
}  // namespace dsnake
