// The NIfTI variants beside single-file NIfTI-1 (framework/io/nifti.cpp): NIfTI-2 single files
// (540-byte header, 64-bit dims, double placement fields; the NIfTI-2 spec), the 64-bit integer
// datatypes (1024 int64, 1280 uint64) in either version, and .hdr/.img pairs. Each file is built
// here byte by byte from one description written out in either version's layout, so that a
// NIfTI-2 file and a NIfTI-1 file of the same image can be compared as read.
#include "framework/io/image_io.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;
using Affine = Eigen::Matrix<double, 3, 4>;  // RAS mm of voxel (i, j, k, 1)

// The fields of a NIfTI header that the tests set, in either version.
struct Header {
  std::array<int64_t, 8> dim{3, 6, 5, 4, 1, 1, 1, 1};
  int16_t datatype = 16;  // float32
  int16_t bitpix = 32;
  std::array<double, 8> pixdim{1, 1, 1, 1, 1, 1, 1, 1};  // pixdim[0]: qfac
  // kAfterHeader: right after the header (and, in a single file, the extension flag)
  static constexpr int64_t kAfterHeader = std::numeric_limits<int64_t>::min();
  int64_t vox_offset = kAfterHeader;
  double scl_slope = 0, scl_inter = 0;
  // By default the sform diag(-1, -1, 1) (RAS): LPS's axes, so that the reader keeps the voxels'
  // order (stored voxel l is voxel l of the image read).
  int32_t qform_code = 0, sform_code = 1;
  std::array<double, 3> quatern{0, 0, 0}, qoffset{0, 0, 0};
  Affine srow = (Affine() << -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 0).finished();
  int32_t xyzt_units = 2 | 8;  // mm, s
  std::string descrip = "built by nifti_formats_test";
  bool big_endian = false;
};

// A field in the header's byte order.
template <class T>
void put(std::string& h, size_t offset, T value, bool swap) {
  std::memcpy(h.data() + offset, &value, sizeof(T));
  if (swap) std::reverse(h.data() + offset, h.data() + offset + sizeof(T));
}

// The header of `g` in NIfTI-`version`'s layout (nifti1.h; the NIfTI-2 spec), followed for a
// single file by the 4-byte extension flag; `pair`: the header of a .hdr/.img pair (magic "ni1"
// or "ni2"; data offset 0 by default).
std::string header_bytes(const Header& g, int version, bool pair = false) {
  const bool s = g.big_endian;
  const size_t size = version == 1 ? 348 : 540;
  std::string h(pair ? size : size + 4, '\0');
  const int64_t offset = g.vox_offset != Header::kAfterHeader ? g.vox_offset : pair ? 0 : int64_t(size + 4);
  if (version == 1) {
    put<int32_t>(h, 0, 348, s);
    for (int i = 0; i < 8; ++i) put<int16_t>(h, 40 + 2 * i, int16_t(g.dim[i]), s);
    put<int16_t>(h, 70, g.datatype, s);
    put<int16_t>(h, 72, g.bitpix, s);
    for (int i = 0; i < 8; ++i) put<float>(h, 76 + 4 * i, float(g.pixdim[i]), s);
    put<float>(h, 108, float(offset), s);
    put<float>(h, 112, float(g.scl_slope), s);
    put<float>(h, 116, float(g.scl_inter), s);
    h[123] = char(g.xyzt_units);
    std::memcpy(h.data() + 148, g.descrip.data(), std::min<size_t>(g.descrip.size(), 80));
    put<int16_t>(h, 252, int16_t(g.qform_code), s);
    put<int16_t>(h, 254, int16_t(g.sform_code), s);
    for (int k = 0; k < 3; ++k) put<float>(h, 256 + 4 * k, float(g.quatern[k]), s);
    for (int k = 0; k < 3; ++k) put<float>(h, 268 + 4 * k, float(g.qoffset[k]), s);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) put<float>(h, 280 + 16 * r + 4 * c, float(g.srow(r, c)), s);
    std::memcpy(h.data() + 344, pair ? "ni1" : "n+1", 4);
  } else {
    put<int32_t>(h, 0, 540, s);
    std::memcpy(h.data() + 4, pair ? "ni2\0\r\n\032\n" : "n+2\0\r\n\032\n", 8);
    put<int16_t>(h, 12, g.datatype, s);
    put<int16_t>(h, 14, g.bitpix, s);
    for (int i = 0; i < 8; ++i) put<int64_t>(h, 16 + 8 * i, g.dim[i], s);
    for (int i = 0; i < 8; ++i) put<double>(h, 104 + 8 * i, g.pixdim[i], s);
    put<int64_t>(h, 168, offset, s);
    put<double>(h, 176, g.scl_slope, s);
    put<double>(h, 184, g.scl_inter, s);
    std::memcpy(h.data() + 240, g.descrip.data(), std::min<size_t>(g.descrip.size(), 80));
    put<int32_t>(h, 344, g.qform_code, s);
    put<int32_t>(h, 348, g.sform_code, s);
    for (int k = 0; k < 3; ++k) put<double>(h, 352 + 8 * k, g.quatern[k], s);
    for (int k = 0; k < 3; ++k) put<double>(h, 376 + 8 * k, g.qoffset[k], s);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) put<double>(h, 400 + 32 * r + 8 * c, g.srow(r, c), s);
    put<int32_t>(h, 500, g.xyzt_units, s);
  }
  return h;
}

// Values of type T in the header's byte order.
template <class T>
std::string stored(const std::vector<T>& values, bool big_endian) {
  std::string out(values.size() * sizeof(T), '\0');
  for (size_t i = 0; i < values.size(); ++i) put<T>(out, i * sizeof(T), values[i], big_endian);
  return out;
}

// float32 voxels whose value is their stored index l (so that every voxel can be found again).
std::string index_values(const Header& g) {
  std::vector<float> v(size_t(g.dim[1] * g.dim[2] * g.dim[3]));
  for (size_t l = 0; l < v.size(); ++l) v[l] = float(l);
  return stored(v, g.big_endian);
}

std::string nifti_file(const Header& g, int version, const std::string& values) {
  return header_bytes(g, version) + values;
}

void gzip_file(const std::string& path, const std::string& bytes) {
  gzFile gz = gzopen(path.c_str(), "wb1");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, bytes.data(), unsigned(bytes.size())), int(bytes.size()));
  gzclose(gz);
}

// The sform of spacing diag(d) with columns rotated by r, offset o (RAS), each entry rounded to
// float: the same numbers in a NIfTI-1 and a NIfTI-2 header.
Affine float_affine(const Eigen::Matrix3d& r, const Eigen::Vector3d& d, const Eigen::Vector3d& o) {
  Affine a;
  a.leftCols<3>() = r * d.asDiagonal();
  a.col(3) = o;
  return a.cast<float>().cast<double>();
}

// Reads `path` as a 3D image with `options`, returning what it printed on stderr.
Image<3> read_capturing(const std::string& path, const ImageReadOptions& options, std::string& err) {
  ::testing::internal::CaptureStderr();
  Image<3> image = read_image<3>(path, options);
  err = ::testing::internal::GetCapturedStderr();
  return image;
}

// The same grid and voxels, the geometry to `tol`.
void expect_same(const Image<3>& a, const Image<3>& b, double tol) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_LE((a.grid().origin - b.grid().origin).cwiseAbs().maxCoeff(), tol);
  EXPECT_LE((a.grid().spacing - b.grid().spacing).cwiseAbs().maxCoeff(), tol);
  EXPECT_LE((a.grid().direction - b.grid().direction).cwiseAbs().maxCoeff(), tol);
  EXPECT_EQ(a.data(), b.data());
}

// x rounded to float. (Through a volatile: GCC 12 at -O3 vectorized two of rotated_header's
// double(float(x)) into copies of x, rounding nothing.)
double float_rounded(double x) {
  volatile float f = float(x);
  return f;
}

// A rotated grid placed by both transforms (the same placement: sform rows and quaternion of one
// rotation, the third axis reversed by qfac -1), every number float-representable.
Header rotated_header() {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d d(1.5, 0.75, 2.0), o(10, -20, 5);
  Eigen::Matrix3d rq = r;
  rq.col(2) = -rq.col(2);
  const Eigen::Quaterniond q(r);
  const double sign = q.w() < 0 ? -1 : 1;
  Header g;
  g.pixdim = {-1, d[0], d[1], d[2], 1, 1, 1, 1};
  g.qform_code = 1;
  g.quatern = {float_rounded(sign * q.x()), float_rounded(sign * q.y()), float_rounded(sign * q.z())};
  g.qoffset = {o[0], o[1], o[2]};
  g.sform_code = 2;
  g.srow = float_affine(rq, d, o);
  return g;
}

// ---------------------------------------------------------------- NIfTI-2

// A NIfTI-2 file holding the numbers of a NIfTI-1 file reads as it does, by every transform
// choice, little- and big-endian, plain and gzipped.
TEST(Nifti2, RotatedSformAndQformReadAsTheSameImageWrittenAsNifti1) {
  const std::string dir = fresh_dir();
  for (const bool big_endian : {false, true}) {
    SCOPED_TRACE(big_endian ? "big-endian" : "little-endian");
    Header g = rotated_header();
    g.big_endian = big_endian;
    write_file(dir + "/v1.nii", nifti_file(g, 1, index_values(g)));
    write_file(dir + "/v2.nii", nifti_file(g, 2, index_values(g)));
    gzip_file(dir + "/v2.nii.gz", nifti_file(g, 2, index_values(g)));
    EXPECT_EQ(image_file_dimension(dir + "/v2.nii"), 3);
    EXPECT_EQ(image_file_dimension(dir + "/v2.nii.gz"), 3);
    for (const NiftiTransform t : {NiftiTransform::kAuto, NiftiTransform::kSform, NiftiTransform::kQform}) {
      SCOPED_TRACE(int(t));
      ImageReadOptions options;
      options.nifti_transform = t;
      std::string err1, err2, err3;
      const Image<3> one = read_capturing(dir + "/v1.nii", options, err1);
      const Image<3> two = read_capturing(dir + "/v2.nii", options, err2);
      const Image<3> gz = read_capturing(dir + "/v2.nii.gz", options, err3);
      expect_same(two, one, 1e-12);
      expect_same(gz, one, 1e-12);
      EXPECT_EQ(err1, "");
      EXPECT_EQ(err2, "");
      EXPECT_FALSE(two.grid().axis_aligned()) << "an oblique grid";
    }
  }
}

// The same warnings, word for word but for the file's name: transforms 5 degrees apart, and a
// transform asked for that the file lacks.
TEST(Nifti2, WarnsAsNifti1Does) {
  const std::string dir = fresh_dir();
  Header g;
  g.qform_code = 1;
  g.qoffset = {3, 4, 5};
  g.sform_code = 1;
  g.srow = float_affine(Eigen::AngleAxisd(5 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix(), {1, 1, 1},
                        {3, 4, 5});
  Header s_only = g;
  s_only.qform_code = 0;
  for (const auto& [name, header] : {std::pair{"d", g}, std::pair{"s", s_only}}) {
    write_file(dir + "/" + name + "1.nii", nifti_file(header, 1, index_values(header)));
    write_file(dir + "/" + name + "2.nii", nifti_file(header, 2, index_values(header)));
  }
  ImageReadOptions want_q;
  want_q.nifti_transform = NiftiTransform::kQform;
  for (const auto& [name, options] : {std::pair{"d", ImageReadOptions{}}, std::pair{"s", want_q}}) {
    SCOPED_TRACE(name);
    std::string err1, err2;
    const Image<3> one = read_capturing(dir + "/" + name + "1.nii", options, err1);
    const Image<3> two = read_capturing(dir + "/" + name + "2.nii", options, err2);
    expect_same(two, one, 1e-12);
    EXPECT_EQ(std::count(err1.begin(), err1.end(), '\n'), 1) << err1;
    const std::string path1 = dir + "/" + name + "1.nii", path2 = dir + "/" + name + "2.nii";
    ASSERT_NE(err1.find(path1), std::string::npos);
    err1.replace(err1.find(path1), path1.size(), path2);
    EXPECT_EQ(err2, err1);
  }
}

// NIfTI-2's placement fields are doubles: an origin and a spacing no float holds are read exactly
// (NIfTI-1's floats would be ~1e-6 off).
TEST(Nifti2, PlacementKeepsDoublePrecision) {
  const std::string dir = fresh_dir();
  const double ox = 10.123456789012345, oy = -7.000000123456789, oz = 0.1, dx = 0.3, dy = 0.7000000001;
  Header g;
  g.sform_code = 1;
  g.srow << -dx, 0, 0, ox, 0, -dy, 0, oy, 0, 0, 1.1, oz;  // RAS -x, -y: LPS +x, +y, no reordering
  write_file(dir + "/s.nii", nifti_file(g, 2, index_values(g)));
  const Image<3> s = read_image<3>(dir + "/s.nii");
  EXPECT_NEAR(s.origin()[0], -ox, 1e-12);
  EXPECT_NEAR(s.origin()[1], -oy, 1e-12);
  EXPECT_NEAR(s.origin()[2], oz, 1e-12);
  EXPECT_NEAR(s.spacing()[0], dx, 1e-12);
  EXPECT_NEAR(s.spacing()[1], dy, 1e-12);
  EXPECT_NEAR(s.spacing()[2], 1.1, 1e-12);
  // The qform: a half turn about z (RAS -> LPS) with double offsets and pixdim.
  Header q;
  q.sform_code = 0;
  q.qform_code = 1;
  q.quatern = {0, 0, 1};
  q.qoffset = {-ox, -oy, oz};
  q.pixdim = {1, dx, dy, 1.1, 1, 1, 1, 1};
  write_file(dir + "/q.nii", nifti_file(q, 2, index_values(q)));
  const Image<3> qi = read_image<3>(dir + "/q.nii");
  EXPECT_NEAR(qi.origin()[0], ox, 1e-12);
  EXPECT_NEAR(qi.origin()[1], oy, 1e-12);
  EXPECT_NEAR(qi.origin()[2], oz, 1e-12);
  EXPECT_NEAR(qi.spacing()[1], dy, 1e-12);
  EXPECT_TRUE(qi.grid().axis_aligned());
  EXPECT_EQ(qi.data(), s.data());
}

// scl_slope and scl_inter (doubles) apply as in NIfTI-1; a 2D file (dim[0] = 2) is 2D; dim[5]
// components make a vector field.
TEST(Nifti2, ScalingTwoDimensionsAndComponents) {
  const std::string dir = fresh_dir();
  Header g;
  g.datatype = 4;  // int16
  g.bitpix = 16;
  g.scl_slope = 0.5;
  g.scl_inter = -1024;
  g.big_endian = true;
  std::vector<int16_t> v(6 * 5 * 4);
  for (size_t i = 0; i < v.size(); ++i) v[i] = int16_t(i * 523 % 65536 - 32768);
  write_file(dir + "/ct.nii", nifti_file(g, 2, stored(v, true)));
  const Image<3> ct = read_image<3>(dir + "/ct.nii");
  for (size_t i = 0; i < v.size(); ++i) ASSERT_EQ(ct[int64_t(i)], float(v[i] * 0.5 - 1024)) << i;

  Header flat;
  flat.dim = {2, 6, 5, 1, 1, 1, 1, 1};
  flat.srow << -0.5, 0, 0, 0, 0, -0.25, 0, 0, 0, 0, 1, 0;
  write_file(dir + "/flat.nii", nifti_file(flat, 2, index_values(flat)));
  EXPECT_EQ(image_file_dimension(dir + "/flat.nii"), 2);
  const Image<2> im = read_image<2>(dir + "/flat.nii");
  EXPECT_EQ(im.spacing(), Point<2>(0.5, 0.25));

  Header field;
  field.dim = {5, 4, 3, 2, 1, 3, 1, 1};
  std::vector<float> components(4 * 3 * 2 * 3);
  for (size_t i = 0; i < components.size(); ++i) components[i] = float(i);  // component c of voxel l: c n + l
  write_file(dir + "/field.nii", nifti_file(field, 2, stored(components, false)));
  const VectorField<3> f = read_vector_field<3>(dir + "/field.nii");
  for (int64_t l = 0; l < 24; ++l)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(f[l][c], double(c * 24 + l)) << l << " " << c;
}

// ---------------------------------------------------------------- 64-bit integers

// int64 (1024) and uint64 (1280) values, in either version and byte order, read as their nearest
// float: above 2^31 and 2^63, and one (2^60 + 2^36 + 1) that rounding through double would put on
// another float (2^60 instead of 2^60 + 2^37).
TEST(Nifti64BitIntegers, ReadAsTheirNearestFloat) {
  const std::string dir = fresh_dir();
  const int64_t tricky = (int64_t(1) << 60) + (int64_t(1) << 36) + 1;
  ASSERT_NE(float(double(tricky)), float(tricky)) << "the value that double rounding gets wrong";
  const std::vector<int64_t> signed_values = {0, 1, -1, 3'000'000'000, -5'000'000'001, tricky, -tricky,
                                              std::numeric_limits<int64_t>::max(), std::numeric_limits<int64_t>::min(),
                                              42, 7, -9};
  const std::vector<uint64_t> unsigned_values = {0, 1, 4'294'967'296, (uint64_t(1) << 63) + (uint64_t(1) << 40),
                                                 uint64_t(tricky), std::numeric_limits<uint64_t>::max(), 5, 6, 7, 8,
                                                 9, 10};
  for (const int version : {1, 2})
    for (const bool big_endian : {false, true}) {
      SCOPED_TRACE("NIfTI-" + std::to_string(version) + (big_endian ? " big-endian" : ""));
      Header g;
      g.dim = {3, 3, 2, 2, 1, 1, 1, 1};
      g.bitpix = 64;
      g.big_endian = big_endian;
      g.datatype = 1024;
      write_file(dir + "/i64.nii", nifti_file(g, version, stored(signed_values, big_endian)));
      g.datatype = 1280;
      write_file(dir + "/u64.nii", nifti_file(g, version, stored(unsigned_values, big_endian)));
      const Image<3> i = read_image<3>(dir + "/i64.nii"), u = read_image<3>(dir + "/u64.nii");
      for (size_t k = 0; k < 12; ++k) {
        EXPECT_EQ(i[int64_t(k)], static_cast<float>(signed_values[k])) << k;
        EXPECT_EQ(u[int64_t(k)], static_cast<float>(unsigned_values[k])) << k;
      }
      EXPECT_EQ(i[5], float(uint64_t(1) << 60) + float(uint64_t(1) << 37));
      // Scaled (scl_slope 2, scl_inter 1): in double, as every scaled type.
      g.datatype = 1024;
      g.scl_slope = 2;
      g.scl_inter = 1;
      write_file(dir + "/scaled.nii", nifti_file(g, version, stored(signed_values, big_endian)));
      const Image<3> s = read_image<3>(dir + "/scaled.nii");
      EXPECT_EQ(s[3], float(3e9 * 2 + 1));
      EXPECT_EQ(s[4], float(-5'000'000'001.0 * 2 + 1));
    }
  // A label map of int64 components read as a vector field (components stored one volume each).
  Header f;
  f.dim = {5, 2, 2, 1, 1, 2, 1, 1};
  f.datatype = 1024;
  f.bitpix = 64;
  const std::vector<int64_t> comps = {tricky, 2, 3, 4, 5, 6, 7, -tricky};
  write_file(dir + "/field.nii", nifti_file(f, 2, stored(comps, false)));
  const VectorField<2> field = read_vector_field<2>(dir + "/field.nii");
  EXPECT_EQ(float(field[0][0]), float(tricky));
  EXPECT_EQ(float(field[3][1]), float(-tricky));
}

// ---------------------------------------------------------------- .hdr/.img pairs

// A pair (NIfTI-1 or NIfTI-2; either file named; gzipped, mixed, upper case; values at an offset
// in the .img) reads as the same .nii does, and converts to a .nii.
TEST(NiftiPair, ReadsAsTheSameNii) {
  const std::string dir = fresh_dir();
  for (const int version : {1, 2}) {
    SCOPED_TRACE("NIfTI-" + std::to_string(version));
    const Header g = rotated_header();
    const std::string values = index_values(g);
    write_file(dir + "/one.nii", nifti_file(g, version, values));
    const Image<3> single = read_image<3>(dir + "/one.nii");
    write_file(dir + "/p.hdr", header_bytes(g, version, /*pair=*/true));
    write_file(dir + "/p.img", values);
    gzip_file(dir + "/z.hdr.gz", header_bytes(g, version, true));
    gzip_file(dir + "/z.img.gz", values);
    write_file(dir + "/mixed.hdr", header_bytes(g, version, true));
    gzip_file(dir + "/mixed.img.gz", values);
    write_file(dir + "/UP.HDR", header_bytes(g, version, true));
    write_file(dir + "/UP.IMG", values);
    Header at16 = g;
    at16.vox_offset = 16;
    write_file(dir + "/at16.hdr", header_bytes(at16, version, true));
    write_file(dir + "/at16.img", std::string(16, '\x1f') + values);
    for (const std::string name : {"p.hdr", "p.img", "z.hdr.gz", "z.img.gz", "mixed.hdr", "mixed.img.gz", "UP.HDR",
                                   "UP.IMG", "at16.img"}) {
      SCOPED_TRACE(name);
      EXPECT_EQ(image_file_dimension(dir + "/" + name), 3);
      expect_same(read_image<3>(dir + "/" + name), single, 0);
    }
    // Raw values that begin with the gzip magic bytes are not taken for gzip data.
    std::vector<float> magic(6 * 5 * 4, 0.f);
    std::memcpy(magic.data(), "\x1f\x8b\x08\x00", 4);
    write_file(dir + "/p.img", stored(magic, false));
    EXPECT_EQ(read_image<3>(dir + "/p.hdr").data().size(), magic.size());
    write_file(dir + "/p.img", values);
    convert_image_file(dir + "/p.hdr", dir + "/out.nii");
    expect_same(read_image<3>(dir + "/out.nii"), single, 1e-5);
  }
}

// What read_image makes of a pair's or a NIfTI-2's header for the images a run writes on its grid:
// a single-file NIfTI-1 with the input's codes, units, description and placement.
TEST(NiftiPair, ImagesWrittenOnTheSourceGridAreSingleFileNifti1) {
  const std::string dir = fresh_dir();
  Header g = rotated_header();
  g.sform_code = 4;  // MNI
  g.qform_code = 3;  // Talairach
  g.xyzt_units = 2 | 16;  // mm, ms
  const std::string values = index_values(g);
  write_file(dir + "/p.hdr", header_bytes(g, 1, true));
  write_file(dir + "/p.img", values);
  write_file(dir + "/two.nii", nifti_file(g, 2, values));
  for (const std::string name : {"p.hdr", "two.nii"}) {
    SCOPED_TRACE(name);
    ImageLayout layout;
    const Image<3> image = read_image<3>(dir + "/" + name, {}, &layout);
    EXPECT_EQ(layout.nifti_header.size(), name == "p.hdr" ? 348u : 540u);
    write_image_on_source_grid<3>(image, layout, dir + "/out.nii", {});
    write_image_on_source_grid<3>(image, layout, dir + "/label.nii.gz", {.label = true});
    const std::string out = read_file(dir + "/out.nii");
    ASSERT_EQ(out.size(), 352 + values.size());
    EXPECT_EQ(out.substr(344, 4), std::string("n+1\0", 4));
    EXPECT_EQ(out.substr(352), values) << "the voxels in the input's order";
    int16_t codes[2];
    std::memcpy(codes, out.data() + 252, 4);
    EXPECT_EQ(codes[0], 3);
    EXPECT_EQ(codes[1], 4);
    EXPECT_EQ(uint8_t(out[123]), 2 | 16);
    EXPECT_EQ(out.substr(148, g.descrip.size()), g.descrip);
    expect_same(read_image<3>(dir + "/out.nii"), image, 1e-5);
    const Image<3> label = read_image<3>(dir + "/label.nii.gz");
    EXPECT_TRUE(label.grid().same_geometry(image.grid(), 1e-5));
  }
  // A NIfTI-2 grid of more than 32767 voxels along an axis is read. On its own grid (what a run
  // writes: result_mask.nii.gz) it is written as NIfTI-2, its header kept, in its byte order;
  // converted (a header built from the geometry) as a native NIfTI-2 too.
  Header wide;
  wide.dim = {3, 40000, 2, 2, 1, 1, 1, 1};
  wide.datatype = 2;
  wide.bitpix = 8;
  wide.pixdim = {1, 0.5f, 2, 3, 1, 1, 1, 1};
  std::string wide_values(160000, '\1');
  wide_values[7] = 9;
  for (const bool swapped : {false, true}) {
    SCOPED_TRACE(swapped ? "big-endian" : "native");
    wide.big_endian = swapped;
    write_file(dir + "/wide.nii", nifti_file(wide, 2, wide_values));
    ImageLayout layout;
    const Image<3> image = read_image<3>(dir + "/wide.nii", {}, &layout);
    EXPECT_EQ(image.size(), GridIndex<3>(40000, 2, 2));
    auto field = [&](const std::string& bytes, size_t offset, auto zero) {
      std::string b = bytes.substr(offset, sizeof zero);
      if (swapped) std::reverse(b.begin(), b.end());
      std::memcpy(&zero, b.data(), sizeof zero);
      return zero;
    };
    for (const bool label : {true, false}) {
      write_image_on_source_grid<3>(image, layout, dir + "/grid_wide.nii", {.label = label});
      const std::string out = read_file(dir + "/grid_wide.nii");
      ASSERT_EQ(out.size(), 544u + 160000u * (label ? 1 : 4));
      EXPECT_EQ(field(out, 0, int32_t(0)), 540);
      EXPECT_EQ(out.substr(4, 8), std::string("n+2\0\r\n\032\n", 8));
      EXPECT_EQ(field(out, 12, int16_t(0)), label ? 2 : 16);  // datatype
      EXPECT_EQ(field(out, 168, int64_t(0)), 544);             // vox_offset
      EXPECT_EQ(field(out, 24, int64_t(0)), 40000);            // dim[1]
      const Image<3> back = read_image<3>(dir + "/grid_wide.nii");
      EXPECT_TRUE(back.grid().same_geometry(image.grid(), 1e-9));
      EXPECT_EQ(back.data(), image.data());
    }
  }
  const Image<3> wide_image = read_image<3>(dir + "/wide.nii");
  convert_image_file(dir + "/wide.nii", dir + "/converted_wide.nii");
  const std::string converted = read_file(dir + "/converted_wide.nii");
  ASSERT_EQ(converted.size(), 544u + 160000u * 4);
  int32_t sizeof_hdr = 0;
  int64_t dim1 = 0;
  std::memcpy(&sizeof_hdr, converted.data(), 4);
  std::memcpy(&dim1, converted.data() + 24, 8);
  EXPECT_EQ(sizeof_hdr, 540);
  EXPECT_EQ(dim1, 40000);
  EXPECT_EQ(converted.substr(4, 8), std::string("n+2\0\r\n\032\n", 8));
  const Image<3> back = read_image<3>(dir + "/converted_wide.nii");
  EXPECT_TRUE(back.grid().same_geometry(wide_image.grid(), 1e-9));
  EXPECT_EQ(back.data(), wide_image.data());
  convert_image_file(dir + "/wide.nii", dir + "/wide.nrrd");
  EXPECT_EQ(read_image<3>(dir + "/wide.nrrd").data(), wide_image.data());
}

// A pair whose other file is missing, whose .img is short, an ANALYZE 7.5 header, a single file's
// magic in a .hdr and a pair's in a .nii, and writing a pair: one InputError each, naming the
// file and the field.
TEST(NiftiPair, MissingOrShortFilesAndOtherMagicsAreRefused) {
  const std::string dir = fresh_dir();
  const Header g;
  const std::string values = index_values(g);
  auto read = [](const std::string& p) { read_image<3>(p); };
  write_file(dir + "/lone.hdr", header_bytes(g, 1, true));
  InputError e = expect_input_error([&] { read(dir + "/lone.hdr"); });
  EXPECT_EQ(e.file(), dir + "/lone.img");
  EXPECT_TRUE(contains(e.message(), "file not found (the image file of the NIfTI pair whose header is " + dir +
                                        "/lone.hdr)")) << e.what();
  write_file(dir + "/orphan.img", values);
  e = expect_input_error([&] { read(dir + "/orphan.img"); });
  EXPECT_EQ(e.file(), dir + "/orphan.hdr");
  EXPECT_TRUE(contains(e.message(), "file not found")) << e.what();
  e = expect_input_error([&] { image_file_dimension(dir + "/orphan.img"); });
  EXPECT_EQ(e.file(), dir + "/orphan.hdr");
  e = expect_input_error([&] { read(dir + "/none.img"); });
  EXPECT_EQ(e.file(), dir + "/none.img");

  for (const int version : {1, 2}) {
    SCOPED_TRACE(version);
    write_file(dir + "/short.hdr", header_bytes(g, version, true));
    write_file(dir + "/short.img", values.substr(0, values.size() - 6));
    expect_bad_file(read, dir + "/short.img", "vox_offset",
                    "data holds " + std::to_string(values.size() - 6) + " bytes, expected " +
                        std::to_string(values.size()));
    gzip_file(dir + "/short.img.gz", values.substr(0, 100));
    fs::remove(dir + "/short.img");
    e = expect_input_error([&] { read(dir + "/short.hdr"); });
    EXPECT_EQ(e.file(), dir + "/short.img.gz");
    EXPECT_EQ(e.message(), "data holds 100 bytes, expected " + std::to_string(values.size()));
    fs::remove(dir + "/short.img.gz");
    Header far = g;
    far.vox_offset = 1 << 20;
    write_file(dir + "/far.hdr", header_bytes(far, version, true));
    write_file(dir + "/far.img", values);
    e = expect_input_error([&] { read(dir + "/far.hdr"); });
    EXPECT_EQ(e.file(), dir + "/far.img");
    EXPECT_EQ(e.where(), "vox_offset");
    EXPECT_TRUE(contains(e.message(), "lies outside the file")) << e.what();
  }

  std::string analyze = header_bytes(g, 1, true);
  std::memset(analyze.data() + 344, 0, 4);
  write_file(dir + "/analyze.hdr", analyze);
  write_file(dir + "/analyze.img", values);
  expect_bad_file(read, dir + "/analyze.hdr", "magic", "ANALYZE 7.5 header, which has no orientation");
  e = expect_input_error([&] { read(dir + "/analyze.img"); });
  EXPECT_EQ(e.file(), dir + "/analyze.hdr");
  EXPECT_TRUE(contains(e.message(), "convert it to NIfTI")) << e.what();
  for (const int version : {1, 2}) {
    write_file(dir + "/single.hdr", header_bytes(g, version));
    write_file(dir + "/single.img", values);
    expect_bad_file(read, dir + "/single.hdr", "magic", "name it .nii");
    write_file(dir + "/paired.nii", header_bytes(g, version, true) + values);
    expect_bad_file(read, dir + "/paired.nii", "magic", "marks the header of a .hdr/.img pair");
  }
  write_file(dir + "/v.nii", nifti_file(g, 1, values));
  for (const std::string out : {"/o.hdr", "/o.img", "/o.hdr.gz"}) {
    e = expect_input_error([&] { convert_image_file(dir + "/v.nii", dir + out); });
    EXPECT_EQ(e.file(), dir + out);
    EXPECT_TRUE(contains(e.message(), "write .nii or .nii.gz")) << e.what();
    EXPECT_FALSE(fs::exists(dir + out));
  }
}

// ---------------------------------------------------------------- bad NIfTI-2 headers

// Each broken NIfTI-2 header is one InputError naming the file and the field (and nothing is
// allocated for what a header merely declares).
TEST(Nifti2, BadHeadersAreOneInputErrorNamingTheField) {
  const std::string dir = fresh_dir(), path = dir + "/bad.nii";
  const Header good;
  const std::string values = index_values(good);
  write_file(path, nifti_file(good, 2, values));
  ASSERT_EQ(read_image<3>(path).size(), GridIndex<3>(6, 5, 4));
  auto read = [](const std::string& p) { read_image<3>(p); };
  auto with = [&](auto change) {
    Header h = good;
    change(h);
    return nifti_file(h, 2, values);
  };
  struct Case {
    std::string bytes, field, words;
  };
  std::string bad_eol = nifti_file(good, 2, values);
  bad_eol[8] = '\n';  // "\r\n" made "\n\n" by a text-mode transfer
  std::string garbage = nifti_file(good, 2, values);
  garbage[0] = 7;
  const std::vector<Case> cases = {
      {nifti_file(good, 2, values).substr(0, 400), "header", "file holds 400 bytes, a NIfTI-2 header needs 540"},
      {nifti_file(good, 2, values).substr(0, 3), "header", "file holds 3 bytes"},
      {garbage, "sizeof_hdr", "not a NIfTI file"},
      {bad_eol, "magic", "altered"},
      {with([](Header& h) { h.vox_offset = 352; }), "vox_offset",
       "inside the header (the values of a NIfTI-2 .nii start at byte 544"},
      {with([](Header& h) { h.vox_offset = 540; }), "vox_offset", "inside the header"},
      {with([](Header& h) { h.vox_offset = 0; }), "vox_offset", "inside the header"},
      {with([](Header& h) { h.vox_offset = -8; }), "vox_offset", "lies outside the file"},
      {with([](Header& h) { h.vox_offset = int64_t(1) << 62; }), "vox_offset", "lies outside the file"},
      {with([](Header& h) { h.vox_offset = 1000; }), "vox_offset", "data holds "},
      {with([](Header& h) { h.datatype = 32; }), "datatype", "unsupported datatype 32"},
      {with([](Header& h) { h.dim[0] = 7; }), "dim", "unsupported dimension 7"},
      {with([](Header& h) { h.dim[2] = 0; }), "dim", "dim[2] = 0 is not positive"},
      {with([](Header& h) { h.dim[1] = int64_t(1) << 40; }), "dim",
       "dim[1] = 1099511627776 is more than the 2147483647 voxels"},
      {with([](Header& h) { h.dim[0] = 4, h.dim[4] = 3; }), "dim", "time series"},
      {with([](Header& h) { h.dim = {3, 2147483647, 2147483647, 2147483647, 1, 1, 1, 1}; }), "dim", "memory limit"},
      {with([](Header& h) { h.dim[1] = 1000; }), "vox_offset", "data holds " + std::to_string(values.size())},
      {with([](Header& h) { h.sform_code = 0, h.pixdim[2] = 0; }), "pixdim", "spacing must be positive"},
      {with([](Header& h) { h.sform_code = 0, h.qform_code = 1, h.quatern[0] = std::nan(""); }), "quatern_b",
       "not a finite number"},
      {with([](Header& h) { h.sform_code = 0, h.qform_code = 1, h.qoffset[2] = INFINITY; }), "qoffset_z",
       "not a finite number"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.words);
    write_file(path, c.bytes);
    expect_bad_file(read, path, c.field, c.words);
  }
  // Under a memory limit that lets any count pass, dims whose product no 64-bit byte count holds
  // are still refused (and a plain file's size bounds the rest).
  ::setenv("DSNAKE_MAX_IMAGE_BYTES", "1e30", 1);
  write_file(path, with([](Header& h) { h.dim = {5, 2147483647, 2147483647, 2147483647, 1, 3, 1, 1}; }));
  expect_bad_file(read, path, "dim", "more than a 64-bit count of bytes holds");
  write_file(path, with([](Header& h) { h.dim = {3, 2147483647, 1000, 1, 1, 1, 1, 1}; }));
  expect_bad_file(read, path, "vox_offset", "data holds " + std::to_string(values.size()) + " bytes, expected ");
  ::unsetenv("DSNAKE_MAX_IMAGE_BYTES");
  // gzipped: the declared values must be within what deflate can expand the file to.
  gzip_file(dir + "/bomb.nii.gz", with([](Header& h) { h.dim = {3, 1000, 1000, 10, 1, 1, 1, 1}; }));
  expect_bad_file(read, dir + "/bomb.nii.gz", "dim", "more than deflate can expand");
}

}  // namespace
}  // namespace dsnake
