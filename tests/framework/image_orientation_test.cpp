// Images stored with flipped or permuted axes (MetaImage TransformMatrix, NIfTI qform and sform)
// read as the same axis-aligned image: every voxel lands at the same world position and holds
// the same value as when the data are stored axis-aligned (framework/io/image_io_detail.h's
// align_axes), in 2D and 3D. An oblique rotation is kept as the grid's direction; written and
// read again through every writer, the geometry comes back.
#include "framework/io/image_io.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstring>
#include <iterator>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;  // tests/framework/io_test_support.h

// The expected image: 4 x 3 x 2 voxels, spacing (1, 2, 3), origin (5, 6, 7), value i + 10 j + 100 k.
Image<3> expected_volume() {
  Image<3> e(Grid<3>{GridIndex<3>(4, 3, 2), Point<3>(1, 2, 3), Point<3>(5, 6, 7)});
  for (int64_t l = 0; l < e.num_voxels(); ++l) {
    const GridIndex<3> i = e.grid().index(l);
    e[l] = float(i[0] + 10 * i[1] + 100 * i[2]);
  }
  return e;
}

// A MetaImage as another program would store `e` with index axis a running along world axis
// to[a] with sign sign[a]; the file's own origin is the world position of its voxel 0.
void write_reoriented_mha(const Image<3>& e, const std::array<int, 3>& to, const std::array<int, 3>& sign,
                          const std::string& path) {
  GridIndex<3> size;
  Point<3> spacing, origin = e.origin();
  for (int a = 0; a < 3; ++a) {
    size[a] = e.size()[to[a]];
    spacing[a] = e.spacing()[to[a]];
    if (sign[a] < 0) origin[to[a]] += e.spacing()[to[a]] * (e.size()[to[a]] - 1);
  }
  std::vector<float> data;
  for (int k = 0; k < size[2]; ++k)
    for (int j = 0; j < size[1]; ++j)
      for (int i = 0; i < size[0]; ++i) {
        const int idx[3] = {i, j, k};
        GridIndex<3> w;
        for (int a = 0; a < 3; ++a) w[to[a]] = sign[a] > 0 ? idx[a] : size[a] - 1 - idx[a];
        data.push_back(e.at(w));
      }
  std::ostringstream h;
  h << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nTransformMatrix =";
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) h << " " << (to[a] == k ? sign[a] : 0);
  h << "\nOffset = " << origin[0] << " " << origin[1] << " " << origin[2] << "\nElementSpacing = " << spacing[0] << " "
    << spacing[1] << " " << spacing[2] << "\nDimSize = " << size[0] << " " << size[1] << " " << size[2]
    << "\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n";
  std::ofstream out(path, std::ios::binary);
  out << h.str();
  out.write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size() * sizeof(float)));
}

void expect_same_image(const Image<3>& got, const Image<3>& want, const std::string& label) {
  SCOPED_TRACE(label);
  ASSERT_EQ(got.size(), want.size());
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(got.spacing()[a], want.spacing()[a], 1e-9);
    EXPECT_NEAR(got.origin()[a], want.origin()[a], 1e-6);
  }
  for (int64_t l = 0; l < want.num_voxels(); ++l) ASSERT_EQ(got[l], want[l]) << "voxel " << l;
}

TEST(ImageOrientation, FlippedAndPermutedMetaImageAxesReadAsTheAlignedImage) {
  const std::string dir = fresh_dir();
  const Image<3> e = expected_volume();
  const std::vector<std::pair<std::array<int, 3>, std::array<int, 3>>> cases = {
      {{0, 1, 2}, {1, 1, 1}},    {{0, 1, 2}, {-1, 1, 1}}, {{0, 1, 2}, {1, -1, -1}},
      {{1, 0, 2}, {1, 1, 1}},    {{2, 0, 1}, {1, -1, 1}}, {{1, 2, 0}, {-1, -1, -1}}};
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string path = dir + "/case" + std::to_string(c) + ".mha";
    write_reoriented_mha(e, cases[c].first, cases[c].second, path);
    expect_same_image(read_image<3>(path), e, path);
  }
}

// A NIfTI sform in NIfTI's RAS world (x_RAS = -x_LPS, y_RAS = -y_LPS): a y axis
// stored reversed (in LPS; srow_y = [0, 2, 0, -y0] in RAS), and the qform identity in RAS, which
// is x and y reversed in LPS.
TEST(ImageOrientation, NiftiSformAndQformFlipsReadAsTheAlignedImage) {
  const std::string dir = fresh_dir();
  const Image<3> e = expected_volume();
  // Stored data: y reversed, and for the qform case x reversed too.
  for (int variant = 0; variant < 2; ++variant) {
    const bool flip_x = variant == 1;
    Image<3> stored(e.grid());
    for (int64_t l = 0; l < e.num_voxels(); ++l) {
      GridIndex<3> i = e.grid().index(l);
      GridIndex<3> w = i;
      w[1] = e.size()[1] - 1 - i[1];
      if (flip_x) w[0] = e.size()[0] - 1 - i[0];
      stored[l] = e.at(w);
    }
    const std::string path = dir + "/v" + std::to_string(variant) + ".nii";
    write_image<3>(stored, path);
    std::string bytes;
    {
      std::ifstream in(path, std::ios::binary);
      std::ostringstream ss;
      ss << in.rdbuf();
      bytes = ss.str();
    }
    auto put_f = [&](size_t at, float x) { std::memcpy(&bytes[at], &x, 4); };
    auto put_s = [&](size_t at, int16_t x) { std::memcpy(&bytes[at], &x, 2); };
    const double y0 = e.origin()[1] + e.spacing()[1] * (e.size()[1] - 1);
    const double x0 = e.origin()[0] + e.spacing()[0] * (e.size()[0] - 1);
    if (!flip_x) {  // sform only
      put_s(252, 0);
      put_s(254, 1);
      const float srow[3][4] = {{-1, 0, 0, -5}, {0, 2, 0, float(-y0)}, {0, 0, 3, 7}};
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) put_f(280 + 16 * r + 4 * c, srow[r][c]);
    } else {  // qform: quaternion (0, 0, 0): the identity in RAS
      put_s(252, 1);
      put_s(254, 0);
      put_f(256, 0), put_f(260, 0), put_f(264, 0);
      put_f(268, float(-x0)), put_f(272, float(-y0)), put_f(276, 7);
    }
    std::ofstream(path, std::ios::binary) << bytes;
    expect_same_image(read_image<3>(path), e, path);
  }
}

TEST(ImageOrientation, A2dFlipReadsAsTheAlignedImage) {
  const std::string dir = fresh_dir();
  Image<2> e(Grid<2>{GridIndex<2>(5, 3), Point<2>(0.5, 2), Point<2>(-1, 4)});
  for (int64_t l = 0; l < e.num_voxels(); ++l) e[l] = float(l);
  // x reversed, then x and y swapped: index axis 0 runs along -world x... stored transposed
  std::ostringstream h;
  h << "ObjectType = Image\nNDims = 2\nBinaryData = True\nBinaryDataByteOrderMSB = False\nTransformMatrix = 0 1 -1 0\nOffset = " << (-1 + 0.5 * 4) << " 4\n"
    << "ElementSpacing = 2 0.5\nDimSize = 3 5\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n";
  // file index (i, j): i along +world y, j along -world x
  std::vector<float> data;
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 3; ++i) data.push_back(e.at(GridIndex<2>(4 - j, i)));
  const std::string path = dir + "/flip.mha";
  {
    std::ofstream out(path, std::ios::binary);
    out << h.str();
    out.write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size() * sizeof(float)));
  }
  const Image<2> got = read_image<2>(path);
  ASSERT_EQ(got.size(), e.size());
  EXPECT_NEAR(got.origin()[0], -1, 1e-9);
  EXPECT_NEAR(got.origin()[1], 4, 1e-9);
  EXPECT_NEAR(got.spacing()[0], 0.5, 1e-12);
  for (int64_t l = 0; l < e.num_voxels(); ++l) ASSERT_EQ(got[l], e[l]) << l;
}


// A rotation about the unit axis u by `deg` degrees (Rodrigues).
Eigen::Matrix3d rotation(Eigen::Vector3d u, double deg) {
  u.normalize();
  const double t = deg * M_PI / 180;
  Eigen::Matrix3d k;
  k << 0, -u[2], u[1], u[2], 0, -u[0], -u[1], u[0], 0;
  return Eigen::Matrix3d::Identity() + std::sin(t) * k + (1 - std::cos(t)) * k * k;
}

// A MetaImage with index axis a along columns[a] (any orthonormal matrix, a reflection too),
// voxel (i, j, k) holding i + 10 j + 100 k.
void write_oblique_mha(const Eigen::Matrix3d& columns, const Point<3>& origin, const Point<3>& spacing,
                       const GridIndex<3>& size, const std::string& path) {
  std::ostringstream h;
  h.precision(17);
  h << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nTransformMatrix =";
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) h << " " << columns(k, a);
  h << "\nOffset = " << origin[0] << " " << origin[1] << " " << origin[2] << "\nElementSpacing = " << spacing[0] << " "
    << spacing[1] << " " << spacing[2] << "\nDimSize = " << size[0] << " " << size[1] << " " << size[2]
    << "\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n";
  std::vector<float> data;
  for (int k = 0; k < size[2]; ++k)
    for (int j = 0; j < size[1]; ++j)
      for (int i = 0; i < size[0]; ++i) data.push_back(float(i + 10 * j + 100 * k));
  std::ofstream out(path, std::ios::binary);
  out << h.str();
  out.write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size() * sizeof(float)));
}

// Every voxel the file stores (write_oblique_mha's layout) is found at its world position in
// the image read: the grid frame's voxel there holds its value.
void expect_voxels_at_their_world_positions(const Image<3>& got, const Eigen::Matrix3d& columns, const Point<3>& origin,
                                            const Point<3>& spacing, const GridIndex<3>& size, double tol) {
  ASSERT_EQ(got.num_voxels(), int64_t(size[0]) * size[1] * size[2]);
  for (int k = 0; k < size[2]; ++k)
    for (int j = 0; j < size[1]; ++j)
      for (int i = 0; i < size[0]; ++i) {
        const Point<3> world = origin + columns * Point<3>(i * spacing[0], j * spacing[1], k * spacing[2]);
        const Point<3> c = got.grid().to_continuous_index(got.grid().to_frame(world));
        GridIndex<3> idx;
        for (int a = 0; a < 3; ++a) {
          idx[a] = int(std::lround(c[a]));
          ASSERT_NEAR(c[a], idx[a], tol) << "voxel (" << i << ", " << j << ", " << k << ") axis " << a;
          ASSERT_TRUE(idx[a] >= 0 && idx[a] < got.size()[a]);
        }
        ASSERT_EQ(got.at(idx), float(i + 10 * j + 100 * k));
      }
}

TEST(ImageOrientation, AnObliqueRotationIsKeptAsTheGridDirection) {
  const std::string dir = fresh_dir();
  const Eigen::Matrix3d r = rotation({1, 2, 3}, 23);
  const Point<3> origin(-12.5, 40, 3), spacing(0.8, 1.1, 2.5);
  const GridIndex<3> size(5, 4, 3);
  write_oblique_mha(r, origin, spacing, size, dir + "/oblique.mha");
  const Image<3> got = read_image<3>(dir + "/oblique.mha");
  EXPECT_LT((got.grid().direction - r).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(got.size(), size);  // a rotation needs no reordering
  expect_voxels_at_their_world_positions(got, r, origin, spacing, size, 1e-9);
}

// A reflection (determinant -1, as a NIfTI qfac of -1 gives) becomes a rotation by reversing
// the last index axis: same world positions, and the frame keeps its orientation.
TEST(ImageOrientation, AnObliqueReflectionBecomesARotationWithTheSameWorldVoxels) {
  const std::string dir = fresh_dir();
  Eigen::Matrix3d m = rotation({-2, 1, 0.5}, 40);
  m.col(2) = -m.col(2);
  const Point<3> origin(7, -3, 11), spacing(1, 0.5, 3);
  const GridIndex<3> size(4, 6, 3);
  write_oblique_mha(m, origin, spacing, size, dir + "/reflected.mha");
  const Image<3> got = read_image<3>(dir + "/reflected.mha");
  EXPECT_NEAR(got.grid().direction.determinant(), 1.0, 1e-12);
  expect_voxels_at_their_world_positions(got, m, origin, spacing, size, 1e-9);
}

// The direction survives MetaImage and NIfTI (RAS on disk, converted both ways; float32 there).
TEST(ImageOrientation, ObliqueGeometryRoundTripsThroughEveryWriter) {
  const std::string dir = fresh_dir();
  Grid<3> g{GridIndex<3>(5, 4, 3), Point<3>(0.8, 1.1, 2.5), Point<3>(-12.5, 40, 3)};
  g.direction = rotation({1, -1, 2}, 67);
  Image<3> oriented(g);
  for (int64_t l = 0; l < oriented.num_voxels(); ++l) oriented[l] = float(l);
  for (const std::string ext : {".mha", ".nii", ".nii.gz"}) {
    SCOPED_TRACE(ext);
    write_image<3>(oriented, dir + "/o" + ext);
    const Image<3> back = read_image<3>(dir + "/o" + ext);
    const double tol = ext == ".mha" ? 1e-12 : 1e-6;
    EXPECT_LT((back.grid().direction - g.direction).cwiseAbs().maxCoeff(), tol);
    EXPECT_LT((back.origin() - g.origin).cwiseAbs().maxCoeff(), 1e-5);
    EXPECT_LT((back.spacing() - g.spacing).cwiseAbs().maxCoeff(), 1e-6);
    ASSERT_EQ(back.size(), g.size);
    for (int64_t l = 0; l < oriented.num_voxels(); ++l) ASSERT_EQ(back[l], oriented[l]);
  }
}

// A vector field of an oblique grid holds frame components (image.h); files hold world
// components, as ITK's vector images: written, the vectors are rotated by the direction, and read
// back they are rotated into the frame again.
TEST(ImageOrientation, VectorFieldsOfAnObliqueGridAreStoredInWorldComponents) {
  const std::string dir = fresh_dir();
  Grid<3> g{GridIndex<3>(3, 2, 2), Point<3>(1, 1, 2), Point<3>(4, 5, 6)};
  g.direction = rotation({1, 1, 1}, 30);  // oblique: kept as the direction on reading
  VectorField<3> f(g);
  for (int64_t i = 0; i < f.num_voxels(); ++i) f[i] = Point<3>(1.0 + double(i), 0, 0.5);
  write_vector_field<3>(f, dir + "/f.mha");
  // The stored components, read as they are on disk: the world's.
  std::ifstream in(dir + "/f.mha", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t data = bytes.size() - size_t(f.num_voxels()) * 3 * sizeof(float);
  float first[3];
  std::memcpy(first, bytes.data() + data, sizeof(first));
  const VectorField<3>& stored = f;  // read back as Points
  const Point<3> world = g.direction * stored[0];
  ASSERT_GT((world - stored[0]).norm(), 0.3);  // the rotation changes the components
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(first[k], world[k], 1e-6) << k;
  const VectorField<3> back = read_vector_field<3>(dir + "/f.mha");
  for (int64_t i = 0; i < f.num_voxels(); ++i) EXPECT_LT((back[i] - stored[i]).norm(), 1e-6) << i;
}

// NIfTI's RAS origin and axes are dsnake's LPS with x and y negated: an axis-aligned LPS image
// is stored as a half turn about z (quatern_d = 1) and srow_x = -spacing_x, srow_y = -spacing_y.
TEST(ImageOrientation, NiftiIsWrittenInRasAndReadBackInLps) {
  const std::string dir = fresh_dir();
  const Image<3> e = expected_volume();  // origin (5, 6, 7)
  write_image<3>(e, dir + "/e.nii");
  std::ifstream in(dir + "/e.nii", std::ios::binary);
  std::string h(348, '\0');
  in.read(h.data(), 348);
  auto f = [&](size_t at) {
    float x;
    std::memcpy(&x, &h[at], 4);
    return double(x);
  };
  EXPECT_EQ(f(256), 0);  // quatern_b
  EXPECT_EQ(f(260), 0);
  EXPECT_EQ(f(264), 1);  // quatern_d
  EXPECT_EQ(f(268), -5);
  EXPECT_EQ(f(272), -6);
  EXPECT_EQ(f(276), 7);
  EXPECT_EQ(f(280), -1);  // srow_x[0] = -spacing_x
  EXPECT_EQ(f(280 + 16 + 4), -2);
  EXPECT_EQ(f(280 + 32 + 8), 3);
  EXPECT_EQ(f(280 + 12), -5);
  expect_same_image(read_image<3>(dir + "/e.nii"), e, "e.nii");
}


// ITK's KmeansTest_T1UCharRaw.nii.gz stores a half turn about (0, 1, 1) / sqrt(2) as the float32
// quaternion (0, 0.70710677, 0.70710677): read as NIfTI's reference code reads it (a = 0), it is a
// signed permutation (x_LPS = i, z = j, -y_LPS = k; 2 x 2 x 3 mm), so the volume is reordered
// axis-aligned, not read as oblique by 0.015 degrees.
TEST(ImageOrientation, ItkNiftiHalfTurnQuaternionIsAPermutation) {
  const Image<3> t1 = read_image<3>(std::string(DSNAKE_SCANS_DIR) + "/itk/KmeansTest_T1UCharRaw.nii.gz");
  EXPECT_TRUE(t1.grid().axis_aligned());
  EXPECT_EQ(t1.size(), GridIndex<3>(128, 62, 128));
  EXPECT_EQ(t1.spacing(), Point<3>(2, 3, 2));
  // qoffset (-0, -254, 0) in RAS is voxel 0 at LPS (0, 254, 0); the file's k axis (62 slices of
  // 3 mm) runs along -y_LPS, so after reordering the first voxel is at y = 254 - 3 * 61 = 71.
  EXPECT_NEAR(t1.origin()[0], 0, 1e-9);
  EXPECT_NEAR(t1.origin()[1], 254 - 3.0 * 61, 1e-9);
  EXPECT_NEAR(t1.origin()[2], 0, 1e-9);
}

#ifdef DSNAKE_SCANS_DIR
// ITK's example data: the same slice stored axis-aligned and with a +30 degree direction.
TEST(ImageOrientation, ItkSliceStoredRotatedKeepsItsVoxelsAndGetsItsDirection) {
  const std::string itk = std::string(DSNAKE_SCANS_DIR) + "/itk/";
  const Image<2> plain = read_image<2>(itk + "BrainProtonDensitySliceBorder20.mhd");
  const Image<2> rotated = read_image<2>(itk + "BrainProtonDensitySliceBorder20DirectionPlus30.mhd");
  ASSERT_EQ(plain.size(), GridIndex<2>(221, 257));
  ASSERT_EQ(rotated.size(), plain.size());
  EXPECT_TRUE(plain.grid().axis_aligned());
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  EXPECT_LT((rotated.grid().direction - r).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_EQ(rotated.data(), plain.data());
  // voxel (100, 50): world = R (100, 50)
  const Point<2> w = rotated.grid().to_world(rotated.grid().to_physical(GridIndex<2>(100, 50)));
  EXPECT_NEAR(w[0], c * 100 - s * 50, 1e-6);
  EXPECT_NEAR(w[1], s * 100 + c * 50, 1e-6);
}
#endif

}  // namespace
}  // namespace dsnake
