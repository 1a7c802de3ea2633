// NIfTI-1 orientation as nibabel reads it (framework/io/nifti.cpp, image_io.h's NiftiTransform):
// the sform when sform_code > 0, else the qform, else pixdim; the warning when the two disagree;
// the nifti_transform override; and images written back on the grid of the file they were read
// from (write_image_on_source_grid) for NIfTI, MetaImage and NRRD inputs. The files are built
// here byte by byte, so that each transform is exactly what the test says.
#include "framework/io/image_io.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace dsnake {
namespace {

using namespace test_support;
using Affine = Eigen::Matrix<double, 3, 4>;  // RAS mm of voxel (i, j, k, 1)

// A NIfTI-1 header's placement fields.
struct NiftiGeometry {
  std::array<int, 3> dim{6, 5, 4};
  std::array<float, 3> pixdim{1, 1, 1};
  int16_t qform_code = 0, sform_code = 0;
  std::array<float, 3> quatern{0, 0, 0};  // b, c, d
  float qfac = 1;
  std::array<float, 3> qoffset{0, 0, 0};
  Affine sform = Affine::Zero();
  int16_t datatype = 16;  // float32 or uint8 (2)
  bool big_endian = false;
};

// A field in the header's byte order.
template <class T>
void put(std::string& h, size_t offset, T value, bool swap) {
  std::memcpy(h.data() + offset, &value, sizeof(T));
  if (swap) std::reverse(h.data() + offset, h.data() + offset + sizeof(T));
}

// A single-file .nii of `g` whose voxel l holds the value l (mod 256 for uint8): stored voxel
// (i, j, k) can be found again after any reordering.
std::string nifti_file(const NiftiGeometry& g) {
  const bool s = g.big_endian;
  std::string h(352, '\0');
  put<int32_t>(h, 0, 348, s);
  const int16_t dim[8] = {3, int16_t(g.dim[0]), int16_t(g.dim[1]), int16_t(g.dim[2]), 1, 1, 1, 1};
  for (int i = 0; i < 8; ++i) put<int16_t>(h, 40 + 2 * i, dim[i], s);
  put<int16_t>(h, 70, g.datatype, s);
  put<int16_t>(h, 72, g.datatype == 2 ? 8 : 32, s);
  put<float>(h, 76, g.qfac, s);
  for (int a = 0; a < 3; ++a) put<float>(h, 80 + 4 * a, g.pixdim[a], s);
  put<float>(h, 108, 352.0f, s);
  put<float>(h, 112, 1.0f, s);
  put<float>(h, 124, 200.0f, s);  // cal_max
  h[123] = 2 | 8;                 // xyzt_units: mm, s
  std::memcpy(h.data() + 148, "built by nifti_orientation_test", 31);
  put<int16_t>(h, 252, g.qform_code, s);
  put<int16_t>(h, 254, g.sform_code, s);
  for (int k = 0; k < 3; ++k) put<float>(h, 256 + 4 * k, g.quatern[k], s);
  for (int k = 0; k < 3; ++k) put<float>(h, 268 + 4 * k, g.qoffset[k], s);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) put<float>(h, 280 + 16 * r + 4 * c, float(g.sform(r, c)), s);
  std::memcpy(h.data() + 344, "n+1", 4);
  const int64_t n = int64_t(g.dim[0]) * g.dim[1] * g.dim[2];
  std::string data;
  for (int64_t l = 0; l < n; ++l) {
    if (g.datatype == 2) {
      data += char(uint8_t(l % 256));
    } else {
      std::string v(4, '\0');
      put<float>(v, 0, float(l), s);
      data += v;
    }
  }
  return h + data;
}

// The sform of spacing diag(d) with columns rotated by r, offset o (RAS).
Affine affine_of(const Eigen::Matrix3d& r, const Eigen::Vector3d& d, const Eigen::Vector3d& o) {
  Affine a;
  a.leftCols<3>() = r * d.asDiagonal();
  a.col(3) = o;
  return a;
}

// Every stored voxel (i, j, k) of a file of dimensions `dim` whose value is its stored index l
// (nifti_file) lies in `image` at the world position `expected` (RAS) maps it to, in LPS, to
// `tol` mm: its continuous index there is whole and holds l.
void expect_voxels_at(const Image<3>& image, const std::array<int, 3>& dim, const Affine& expected, double tol,
                      bool bytes = false) {
  const Grid<3>& g = image.grid();
  double worst = 0;
  for (int k = 0; k < dim[2]; ++k)
    for (int j = 0; j < dim[1]; ++j)
      for (int i = 0; i < dim[0]; ++i) {
        const Eigen::Vector3d ras = expected * Eigen::Vector4d(i, j, k, 1);
        const Point<3> lps(-ras[0], -ras[1], ras[2]);
        const Point<3> c = g.to_continuous_index(g.to_frame(lps));
        const GridIndex<3> at(int(std::lround(c[0])), int(std::lround(c[1])), int(std::lround(c[2])));
        ASSERT_TRUE((at.array() >= 0).all() && (at.array() < g.size.array()).all()) << i << " " << j << " " << k;
        worst = std::max(worst, (g.to_world(g.to_physical(at)) - lps).norm());
        const int64_t l = i + int64_t(dim[0]) * (j + int64_t(dim[1]) * k);
        ASSERT_EQ(image.at(at), float(bytes ? l % 256 : l)) << i << " " << j << " " << k;
      }
  EXPECT_LE(worst, tol);
}

// Reads `path` with `options`, returning what it printed on stderr.
Image<3> read_capturing(const std::string& path, const ImageReadOptions& options, std::string& stderr_text) {
  ::testing::internal::CaptureStderr();
  Image<3> image = read_image<3>(path, options);
  stderr_text = ::testing::internal::GetCapturedStderr();
  return image;
}

int lines_of(const std::string& s) { return int(std::count(s.begin(), s.end(), '\n')); }

// The INIA19 atlas pair's layout (built here; the atlas itself is held out): the label map has a
// zero-offset qform (code 1) and the real origin in its sform (code 2), the T1 image an sform
// only. nibabel's affine of both is the sform; the labels warn that their transforms disagree.
TEST(NiftiOrientation, AtlasPairWithZeroQformReadsOntoTheSformLikeNibabel) {
  const std::string dir = fresh_dir();
  NiftiGeometry labels;
  labels.dim = {20, 24, 16};
  labels.pixdim = {0.5f, 0.5f, 0.5f};
  labels.qform_code = 1;
  labels.sform_code = 2;
  labels.sform = affine_of(Eigen::Matrix3d::Identity(), {0.5, 0.5, 0.5}, {-42, -57.5, -30});
  labels.datatype = 2;
  NiftiGeometry t1 = labels;
  t1.qform_code = 0;
  t1.datatype = 16;
  write_file(dir + "/labels.nii", nifti_file(labels));
  write_file(dir + "/t1.nii", nifti_file(t1));

  std::string err;
  const Image<3> l = read_capturing(dir + "/labels.nii", {}, err);
  expect_voxels_at(l, labels.dim, labels.sform, 1e-4, /*bytes=*/true);
  EXPECT_EQ(lines_of(err), 1) << err;
  EXPECT_TRUE(contains(err, "dsnake: warning: " + dir + "/labels.nii: sform and qform disagree by ")) << err;
  EXPECT_TRUE(contains(err, "using the sform (image.nifti_transform")) << err;
  // The size of the disagreement: the origins are |(-42, -57.5, -30)| = 77.3 mm apart, the axes agree.
  EXPECT_TRUE(contains(err, "by 77.3 mm / 0 degrees")) << err;

  const Image<3> t = read_capturing(dir + "/t1.nii", {}, err);
  expect_voxels_at(t, t1.dim, t1.sform, 1e-4);
  EXPECT_EQ(err, "");
  EXPECT_TRUE((l.grid().origin - t.grid().origin).norm() < 1e-9);  // one world for the pair

  // image.nifti_transform = qform: the labels at the qform's zero offset, without a warning.
  ImageReadOptions qform;
  qform.nifti_transform = NiftiTransform::kQform;
  const Image<3> lq = read_capturing(dir + "/labels.nii", qform, err);
  expect_voxels_at(lq, labels.dim, affine_of(Eigen::Matrix3d::Identity(), {0.5, 0.5, 0.5}, {0, 0, 0}), 1e-4, true);
  EXPECT_EQ(err, "");
}

TEST(NiftiOrientation, SformOnlyQformOnlyAndBothEqual) {
  const std::string dir = fresh_dir();
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
  const Eigen::Vector3d d(1.5, 0.8, 2.0), o(10, -20, 5);
  // The qform of rotation r with the third axis negated (qfac -1): a left-handed (LAS-like) grid.
  Eigen::Matrix3d rq = r;
  rq.col(2) = -rq.col(2);
  const Eigen::Quaterniond q(r);
  const float sign = q.w() < 0 ? -1.0f : 1.0f;

  NiftiGeometry sform_only;
  sform_only.pixdim = {1, 1, 1};  // the sform's column norms are the spacing, not pixdim
  sform_only.sform_code = 1;
  sform_only.sform = affine_of(r, d, o);
  NiftiGeometry qform_only;
  qform_only.pixdim = {float(d[0]), float(d[1]), float(d[2])};
  qform_only.qform_code = 1;
  qform_only.qfac = -1;
  qform_only.quatern = {sign * float(q.x()), sign * float(q.y()), sign * float(q.z())};
  qform_only.qoffset = {float(o[0]), float(o[1]), float(o[2])};
  NiftiGeometry both = qform_only;  // the same placement twice
  both.sform_code = 2;
  both.sform = affine_of(rq, d, o);
  NiftiGeometry big = both;
  big.big_endian = true;
  write_file(dir + "/s.nii", nifti_file(sform_only));
  write_file(dir + "/q.nii", nifti_file(qform_only));
  write_file(dir + "/both.nii", nifti_file(both));
  write_file(dir + "/big.nii", nifti_file(big));

  std::string err;
  expect_voxels_at(read_capturing(dir + "/s.nii", {}, err), sform_only.dim, sform_only.sform, 1e-4);
  EXPECT_EQ(err, "");
  const Affine qa = affine_of(rq, d, o);
  expect_voxels_at(read_capturing(dir + "/q.nii", {}, err), qform_only.dim, qa, 1e-4);
  EXPECT_EQ(err, "");
  expect_voxels_at(read_capturing(dir + "/both.nii", {}, err), both.dim, qa, 1e-4);
  EXPECT_EQ(err, "") << "equal transforms: no warning";
  expect_voxels_at(read_capturing(dir + "/big.nii", {}, err), big.dim, qa, 1e-4);
  EXPECT_EQ(err, "");

  // A requested transform the file lacks: one warning line, and the one it has.
  ImageReadOptions want_s, want_q;
  want_s.nifti_transform = NiftiTransform::kSform;
  want_q.nifti_transform = NiftiTransform::kQform;
  expect_voxels_at(read_capturing(dir + "/q.nii", want_s, err), qform_only.dim, qa, 1e-4);
  EXPECT_EQ(err, "dsnake: warning: " + dir + "/q.nii: the sform was asked for (image.nifti_transform or "
                 "--nifti-transform), but its sform_code is 0; using the qform\n");
  expect_voxels_at(read_capturing(dir + "/s.nii", want_q, err), sform_only.dim, sform_only.sform, 1e-4);
  EXPECT_EQ(lines_of(err), 1) << err;
  EXPECT_TRUE(contains(err, "the qform was asked for (image.nifti_transform or --nifti-transform), but its qform_code "
                           "is 0; using the sform")) << err;
}

// Transforms that differ only in direction (by 5 degrees about z, the same origin): the sform
// by default, with the warning giving the angle; the qform on request.
TEST(NiftiOrientation, DisagreeingTransformsWarnOnceAndTheOverridePicksEither) {
  const std::string dir = fresh_dir();
  const double angle = 5.0 * 3.14159265358979323846 / 180;
  const Eigen::Matrix3d rz = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  NiftiGeometry g;
  g.pixdim = {1, 1, 1};
  g.qform_code = 1;
  g.qoffset = {3, 4, 5};
  g.sform_code = 1;
  g.sform = affine_of(rz, {1, 1, 1}, {3, 4, 5});
  write_file(dir + "/d.nii", nifti_file(g));
  std::string err;
  expect_voxels_at(read_capturing(dir + "/d.nii", {}, err), g.dim, g.sform, 1e-4);
  EXPECT_EQ(lines_of(err), 1) << err;
  EXPECT_TRUE(contains(err, dir + "/d.nii: sform and qform disagree by ")) << err;
  EXPECT_TRUE(contains(err, " mm / 5 degrees; using the sform")) << err;
  ImageReadOptions q;
  q.nifti_transform = NiftiTransform::kQform;
  expect_voxels_at(read_capturing(dir + "/d.nii", q, err), g.dim, affine_of(Eigen::Matrix3d::Identity(), {1, 1, 1}, {3, 4, 5}), 1e-4);
  EXPECT_EQ(err, "");
  ImageReadOptions s;
  s.nifti_transform = NiftiTransform::kSform;
  expect_voxels_at(read_capturing(dir + "/d.nii", s, err), g.dim, g.sform, 1e-4);
  EXPECT_EQ(err, "") << "a transform asked for by name is not warned about";

  // Within a voxel and a degree: the same placement for every purpose, no warning.
  g.qoffset = {3.4f, 4, 5};
  g.sform = affine_of(Eigen::AngleAxisd(0.5 * 3.14159265358979323846 / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                      {1, 1, 1}, {3, 4, 5});
  write_file(dir + "/near.nii", nifti_file(g));
  read_capturing(dir + "/near.nii", {}, err);
  EXPECT_EQ(err, "");
}

// An sform whose column for an axis of several voxels is zero (all of them at one point; nibabel's
// affine is singular): the qform places the voxels, or pixdim when there is none, with one
// warning line naming the axis.
TEST(NiftiOrientation, AnSformWithAZeroColumnGivesWayToTheQformWithAWarning) {
  const std::string dir = fresh_dir();
  NiftiGeometry g;
  g.pixdim = {1.5f, 1, 2};
  g.qform_code = 1;
  g.qoffset = {3, 4, 5};
  g.sform_code = 2;
  g.sform = affine_of(Eigen::Matrix3d::Identity(), {2, 2, 2}, {7, 8, 9});
  g.sform.col(1).setZero();
  write_file(dir + "/flat_q.nii", nifti_file(g));
  std::string err;
  expect_voxels_at(read_capturing(dir + "/flat_q.nii", {}, err), g.dim,
                   affine_of(Eigen::Matrix3d::Identity(), {1.5, 1, 2}, {3, 4, 5}), 1e-4);
  EXPECT_EQ(err, "dsnake: warning: " + dir + "/flat_q.nii: sform: its column for axis 1 (5 voxels) is zero or not "
                 "finite, which places them all at one point; using the qform\n");
  g.qform_code = 0;
  g.sform.setZero();
  write_file(dir + "/flat.nii", nifti_file(g));
  expect_voxels_at(read_capturing(dir + "/flat.nii", {}, err), g.dim,
                   affine_of(Eigen::Matrix3d::Identity(), {1.5, 1, 2}, {0, 0, 0}), 1e-4);
  EXPECT_EQ(lines_of(err), 1) << err;
  EXPECT_TRUE(contains(err, "its column for axis 0 (6 voxels) is zero or not finite, which places them all at one "
                            "point; using pixdim at the origin")) << err;
}

// A qform parameter that is not a finite number is refused naming the field (a NaN quaternion was
// reported as a sheared grid); an sform in use leaves the qform unread.
TEST(NiftiOrientation, ANonFiniteQformParameterIsRefusedNamingIt) {
  const std::string dir = fresh_dir();
  NiftiGeometry g;
  g.qform_code = 1;
  g.quatern = {0, std::numeric_limits<float>::quiet_NaN(), 0};
  write_file(dir + "/nan_q.nii", nifti_file(g));
  const InputError e = expect_input_error([&] { read_image<3>(dir + "/nan_q.nii"); });
  EXPECT_EQ(e.file(), dir + "/nan_q.nii");
  EXPECT_EQ(e.where(), "quatern_c");
  EXPECT_TRUE(contains(e.message(), "quaternion parameter is not a finite number")) << e.what();
  EXPECT_FALSE(contains(e.message(), "shear")) << e.what();
  g.quatern = {0, 0, 0};
  g.qoffset = {0, 0, std::numeric_limits<float>::infinity()};
  write_file(dir + "/inf_offset.nii", nifti_file(g));
  EXPECT_EQ(expect_input_error([&] { read_image<3>(dir + "/inf_offset.nii"); }).where(), "qoffset_z");
  g.sform_code = 1;
  g.sform = affine_of(Eigen::Matrix3d::Identity(), {1, 1, 1}, {0, 0, 0});
  write_file(dir + "/with_sform.nii", nifti_file(g));
  EXPECT_EQ(read_image<3>(dir + "/with_sform.nii").grid().size, GridIndex<3>(6, 5, 4));
}

// The header read for the dimension alone says nothing (the image is read afterwards and warns then).
TEST(NiftiOrientation, FileDimensionDoesNotWarn) {
  const std::string dir = fresh_dir();
  NiftiGeometry g;
  g.qform_code = 1;
  g.sform_code = 1;
  g.sform = affine_of(Eigen::Matrix3d::Identity(), {1, 1, 1}, {50, 0, 0});
  write_file(dir + "/d.nii", nifti_file(g));
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(image_file_dimension(dir + "/d.nii"), 3);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

// The 348 header bytes of a written file, and its values from byte 352 (uncompressed .nii).
struct WrittenNifti {
  std::string header, values;
};
WrittenNifti written(const std::string& path) {
  const std::string bytes = read_file(path);
  EXPECT_GE(bytes.size(), 352u);
  return {bytes.substr(0, 348), bytes.substr(352)};
}

// Header bytes [offset, offset + n).
std::string field(const std::string& h, size_t offset, size_t n) { return h.substr(offset, n); }

// A NIfTI input stored LAS (x reversed against RAS, so the reader reorders it) with an oblique
// reflection in the qform and the same in the sform: the image written on its grid has its
// header (transforms, codes, pixdim, units, description) and its voxels in its order.
TEST(NiftiOrientation, ImagesWrittenOnTheSourceGridKeepTheNiftiHeaderAndVoxelOrder) {
  const std::string dir = fresh_dir();
  for (const bool oblique : {false, true}) {
    for (const bool big_endian : {false, true}) {
      SCOPED_TRACE(std::string(oblique ? "oblique" : "axis-aligned") + (big_endian ? ", big-endian" : ""));
      const Eigen::Matrix3d r = oblique ? Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix()
                                        : Eigen::Matrix3d::Identity();
      Eigen::Matrix3d las = r;
      las.col(0) = -las.col(0);  // a reflection: the reader reverses an axis
      NiftiGeometry g;
      g.dim = {7, 5, 3};
      g.pixdim = {1.0f, 1.25f, 2.0f};
      g.sform_code = 2;
      g.sform = affine_of(las, {1.0, 1.25, 2.0}, {10, -20, 5});
      g.big_endian = big_endian;
      const std::string in = dir + "/in.nii";
      write_file(in, nifti_file(g));
      ImageLayout layout;
      const Image<3> image = read_image<3>(in, {}, &layout);
      EXPECT_EQ(layout.path, in);
      EXPECT_EQ(layout.nifti_header, read_file(in).substr(0, 348));
      EXPECT_FALSE(layout.to == (std::array<int, 3>{0, 1, 2}) && layout.sign == (std::array<int, 3>{1, 1, 1}))
          << "the reader reordered the voxels";
      write_image_on_source_grid<3>(image, layout, dir + "/float.nii", {});
      write_image_on_source_grid<3>(image, layout, dir + "/label.nii", {.label = true});
      const std::string source = read_file(in);
      const WrittenNifti f = written(dir + "/float.nii"), l = written(dir + "/label.nii");
      // The placement and the rest of the header as the input's (byte for byte: the same byte order).
      for (const auto& [offset, n] : std::vector<std::pair<size_t, size_t>>{
               {0, 4}, {40, 16}, {76, 32}, {123, 1}, {148, 80}, {252, 92}, {344, 4}}) {
        EXPECT_EQ(field(f.header, offset, n), field(source, offset, n)) << "bytes at " << offset;
        EXPECT_EQ(field(l.header, offset, n), field(source, offset, n)) << "bytes at " << offset;
      }
      const int16_t u8 = big_endian ? int16_t(0x0200) : int16_t(2);
      int16_t datatype;
      std::memcpy(&datatype, l.header.data() + 70, 2);
      EXPECT_EQ(datatype, u8);
      // The voxels in the input's order: the float file is the input's data, the label file its bytes.
      EXPECT_EQ(f.values, source.substr(352));
      ASSERT_EQ(l.values.size(), size_t(7 * 5 * 3));
      for (size_t i = 0; i < l.values.size(); ++i) EXPECT_EQ(uint8_t(l.values[i]), uint8_t(i)) << i;
      // Read back, both give the image as it was read.
      EXPECT_EQ(read_image<3>(dir + "/float.nii").data(), image.data());
      EXPECT_TRUE(read_image<3>(dir + "/float.nii").grid().same_geometry(image.grid()));
    }
  }
}

// MetaImage (a signed permutation of the axes) and NRRD (an oblique reflection, which the reader
// makes a rotation by reversing the last axis): the NIfTI written on the source grid has the
// file's dimensions and voxel order, and a header whose affine is the file's (in RAS).
TEST(NiftiOrientation, ImagesWrittenOnTheSourceGridOfOtherFormats) {
  const std::string dir = fresh_dir();
  const std::array<int64_t, 3> size{6, 4, 3};
  const int64_t n = size[0] * size[1] * size[2];
  std::string data(size_t(n) * 4, '\0');
  for (int64_t l = 0; l < n; ++l) {
    const float v = float(l);
    std::memcpy(data.data() + 4 * l, &v, 4);
  }
  // LPS world: axis 0 along -x (1.5 mm), axis 1 along +z (2 mm), axis 2 along +y (1 mm).
  write_file(dir + "/in.mha", "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
                              "TransformMatrix = -1 0 0 0 0 1 0 1 0\nOffset = 4 5 6\nElementSpacing = 1.5 2 1\n"
                              "DimSize = 6 4 3\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n" + data);
  Eigen::Matrix3d mha_lps;
  mha_lps << -1.5, 0, 0, 0, 0, 1, 0, 2, 0;
  // An oblique reflection in LPS: rotation about z with the last axis negated.
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Matrix3d nrrd_lps = rot * Eigen::Vector3d(1.0, 1.5, -2.0).asDiagonal();
  auto vec = [](const Eigen::Vector3d& v) {
    char buf[128];
    std::snprintf(buf, sizeof(buf), "(%.17g,%.17g,%.17g)", v[0], v[1], v[2]);
    return std::string(buf);
  };
  write_file(dir + "/in.nrrd", "NRRD0004\ntype: float\ndimension: 3\nspace: left-posterior-superior\nsizes: 6 4 3\n"
                               "space directions: " + vec(nrrd_lps.col(0)) + " " + vec(nrrd_lps.col(1)) + " " +
                               vec(nrrd_lps.col(2)) + "\nkinds: domain domain domain\nendian: little\nencoding: raw\n"
                               "space origin: (7,8,9)\n\n" + data);
  const std::pair<std::string, std::pair<Eigen::Matrix3d, Eigen::Vector3d>> inputs[] = {
      {"in.mha", {mha_lps, Eigen::Vector3d(4, 5, 6)}}, {"in.nrrd", {nrrd_lps, Eigen::Vector3d(7, 8, 9)}}};
  for (const auto& [name, lps] : inputs) {
    SCOPED_TRACE(name);
    ImageLayout layout;
    const Image<3> image = read_image<3>(dir + "/" + name, {}, &layout);
    EXPECT_TRUE(layout.nifti_header.empty());
    write_image_on_source_grid<3>(image, layout, dir + "/out.nii", {});
    const WrittenNifti w = written(dir + "/out.nii");
    EXPECT_EQ(w.values, data) << "the voxels in the file's order";
    int16_t dim[4], codes[2];
    std::memcpy(dim, w.header.data() + 40, 8);
    std::memcpy(codes, w.header.data() + 252, 4);
    EXPECT_EQ(dim[1], 6);
    EXPECT_EQ(dim[2], 4);
    EXPECT_EQ(dim[3], 3);
    EXPECT_EQ(codes[0], 1);
    EXPECT_EQ(codes[1], 1);
    // The sform in RAS: the LPS affine with x and y negated.
    Affine expected;
    expected.leftCols<3>() = Eigen::Vector3d(-1, -1, 1).asDiagonal() * lps.first;
    expected.col(3) = Eigen::Vector3d(-1, -1, 1).asDiagonal() * lps.second;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) {
        float v;
        std::memcpy(&v, w.header.data() + 280 + 16 * r + 4 * c, 4);
        EXPECT_NEAR(v, expected(r, c), 1e-5) << "srow " << r << " column " << c;
      }
    // And the qform agrees: read back through it, the image as read from the input.
    ImageReadOptions q;
    q.nifti_transform = NiftiTransform::kQform;
    const Image<3> back = read_image<3>(dir + "/out.nii", q);
    EXPECT_EQ(back.data(), image.data());
    EXPECT_LE((back.grid().origin - image.grid().origin).norm(), 1e-4);
    EXPECT_LE((back.grid().direction - image.grid().direction).cwiseAbs().maxCoeff(), 1e-5);
  }
}

// dsnake convert to a format that stores a direction keeps the input's voxel order (the same
// bytes for float32 data), to INRIMAGE the axis-aligned grid; read back, all are the input.
TEST(NiftiOrientation, ConvertKeepsTheStoredVoxelOrderWhereTheFormatHasADirection) {
  const std::string dir = fresh_dir();
  NiftiGeometry g;
  g.dim = {5, 4, 3};
  g.sform_code = 1;
  g.sform = affine_of(Eigen::Vector3d(-1, 1, -1).asDiagonal(), {1.0, 2.0, 1.5}, {3, 4, 5});  // x and z reversed
  write_file(dir + "/in.nii", nifti_file(g));
  const Image<3> in = read_image<3>(dir + "/in.nii");
  const std::string data = read_file(dir + "/in.nii").substr(352);
  for (const char* out : {"out.nii", "out.mha", "out.nrrd", "out.inr"}) {
    SCOPED_TRACE(out);
    convert_image_file(dir + "/in.nii", dir + "/" + out);
    const std::string bytes = read_file(dir + "/" + out);
    const bool stored_order = bytes.size() >= data.size() && bytes.compare(bytes.size() - data.size(), data.size(), data) == 0;
    EXPECT_EQ(stored_order, std::string(out) != "out.inr");
    const Image<3> back = read_image<3>(dir + "/" + out);
    EXPECT_EQ(back.data(), in.data());
    EXPECT_TRUE(back.grid().same_geometry(in.grid(), 1e-5));
  }
}

}  // namespace
}  // namespace dsnake
