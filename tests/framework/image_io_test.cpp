// Round trips and error reports of framework/image_io: MetaImage (raw, separate .raw, zlib,
// 64-bit integers), NIfTI-1 (.nii, .nii.gz, scaled integer types, big-endian headers), PNG,
// vector fields. NIfTI-2, pairs and NIfTI's 64-bit integers: nifti_formats_test.cpp.
#include "framework/io/image_io.h"
#include "framework/io/raster_codecs.h"
#include "framework/io/image_io_detail.h"

#include "framework/core/errors.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
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

// A 3D test volume with anisotropic spacing, an offset origin and non-round values.
Image<3> test_volume() {
  Grid<3> g;
  g.size = GridIndex<3>(5, 4, 3);
  g.spacing = Point<3>(0.7, 1.3, 2.5);
  g.origin = Point<3>(-3.2, 4.1, 10.05);
  Image<3> im(g);
  for (int64_t i = 0; i < im.num_voxels(); ++i) im[i] = float(std::sin(0.37 * double(i)) * 1000.0 + 0.125);
  return im;
}

Image<2> test_image_2d() {
  Grid<2> g;
  g.size = GridIndex<2>(7, 5);
  g.spacing = Point<2>(0.3, 1.7);
  g.origin = Point<2>(2.5, -1.25);
  Image<2> im(g);
  for (int64_t i = 0; i < im.num_voxels(); ++i) im[i] = float(i * 3 % 256);
  return im;
}

template <int D>
void expect_same_image(const Image<D>& a, const Image<D>& b, bool float_geometry = false) {
  ASSERT_EQ(a.size(), b.size());
  for (int k = 0; k < D; ++k) {
    // NIfTI stores spacing and origin as float32.
    const double sa = float_geometry ? double(float(a.spacing()[k])) : a.spacing()[k];
    const double oa = float_geometry ? double(float(a.origin()[k])) : a.origin()[k];
    EXPECT_EQ(sa, b.spacing()[k]) << "axis " << k;
    EXPECT_EQ(oa, b.origin()[k]) << "axis " << k;
  }
  EXPECT_EQ(a.data(), b.data());
}

// Files in a folder: checks that writers leave no temporary file behind.
std::vector<std::string> files_in(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(ImageIo, MhaRoundTripKeepsSpacingAndOrigin) {
  const std::string dir = fresh_dir(), path = dir + "/v.mha";
  const Image<3> im = test_volume();
  write_image(im, path);
  EXPECT_EQ(image_file_dimension(path), 3);
  expect_same_image(im, read_image<3>(path));
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"v.mha"});
}

TEST(ImageIo, FileDimensionReadsOnlyTheHeaderOfLargeFiles) {
  const std::string dir = fresh_dir();
  Grid<3> g;
  g.size = GridIndex<3>(64, 64, 9);
  Image<3> im(g, 1.5f);
  for (const std::string ext : {".mha", ".nii", ".nii.gz"}) {
    write_image(im, dir + "/big" + ext);
    EXPECT_EQ(image_file_dimension(dir + "/big" + ext), 3) << ext;
    EXPECT_EQ(read_image<3>(dir + "/big" + ext).data(), im.data()) << ext;
  }
}

TEST(ImageIo, MhdRoundTripUsesSeparateRawFile) {
  const std::string dir = fresh_dir(), path = dir + "/v.mhd";
  const Image<3> im = test_volume();
  write_image(im, path);
  EXPECT_EQ(files_in(dir), (std::vector<std::string>{"v.mhd", "v.raw"}));
  EXPECT_TRUE(contains(read_file(path), "ElementDataFile = v.raw"));
  EXPECT_EQ(fs::file_size(dir + "/v.raw"), size_t(im.num_voxels() * 4));
  expect_same_image(im, read_image<3>(path));
}

TEST(ImageIo, CompressedMetaImageRoundTrip) {
  const std::string dir = fresh_dir();
  const Image<3> im = test_volume();
  ImageWriteOptions options;
  options.compress = true;
  write_image(im, dir + "/v.mha", options);
  EXPECT_TRUE(contains(read_file(dir + "/v.mha"), "CompressedData = True"));
  expect_same_image(im, read_image<3>(dir + "/v.mha"));
  write_image(im, dir + "/w.mhd", options);
  EXPECT_TRUE(fs::exists(dir + "/w.zraw"));
  expect_same_image(im, read_image<3>(dir + "/w.mhd"));
}

// A label map (ImageWriteOptions::label) in every format that stores one, raw and compressed:
// one byte per voxel, the values rounded and clamped to [0, 255], the geometry kept. The
// uncompressed files hold exactly header + one byte per voxel.
TEST(ImageIo, LabelMapsRoundTripAsBytesInEveryFormat) {
  const std::string dir = fresh_dir();
  const Image<3> source = test_volume();
  Image<3> labels(source.grid());
  const float values[] = {-3.f, 0.4f, 1.6f, 7.f, 254.6f, 300.f};
  for (int64_t i = 0; i < labels.num_voxels(); ++i) labels[i] = values[i % 6];
  Image<3> expected(source.grid());
  const float stored[] = {0.f, 0.f, 2.f, 7.f, 255.f, 255.f};
  for (int64_t i = 0; i < expected.num_voxels(); ++i) expected[i] = stored[i % 6];
  for (const bool compress : {false, true})
    for (const std::string ext : {".mha", ".mhd", ".nrrd", ".nhdr", ".nii", ".nii.gz"}) {
      if (compress && (ext == ".nii" || ext == ".nii.gz")) continue;  // NIfTI compresses by its name
      const std::string path = dir + "/l" + (compress ? "z" : "") + ext;
      write_image(labels, path, ImageWriteOptions{.compress = compress, .label = true});
      expect_same_image(expected, read_image<3>(path), ext.starts_with(".nii"));  // NIfTI: float geometry
    }
  const int64_t n = labels.num_voxels();
  EXPECT_EQ(fs::file_size(dir + "/l.nii"), size_t(352 + n));
  EXPECT_EQ(fs::file_size(dir + "/l.raw"), size_t(n));
  const std::string mha = read_file(dir + "/l.mha");
  ASSERT_TRUE(contains(mha, "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n"));
  EXPECT_EQ(mha.size() - (mha.find("LOCAL\n") + 6), size_t(n));
  EXPECT_TRUE(contains(read_file(dir + "/lz.mha"), "CompressedData = True"));
}

// A MetaImage as another program writes it: big-endian MET_SHORT, zlib-compressed by the test,
// ElementSize and Position instead of ElementSpacing and Offset, and a TransformMatrix that swaps
// two axes.
TEST(ImageIo, ReadsForeignCompressedBigEndianMetaImage) {
  const std::string dir = fresh_dir(), path = dir + "/f.mha";
  const int nx = 4, ny = 3, nz = 2;
  std::string raw;
  std::vector<int16_t> values;
  for (int i = 0; i < nx * ny * nz; ++i) {
    const int16_t v = int16_t(i * 300 - 3000);
    values.push_back(v);
    raw.push_back(char((uint16_t(v) >> 8) & 0xff));
    raw.push_back(char(uint16_t(v) & 0xff));
  }
  uLongf n = compressBound(raw.size());
  std::string z(n, '\0');
  ASSERT_EQ(compress(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(raw.data()), raw.size()), Z_OK);
  z.resize(n);
  write_file(path, "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = True\n"
                   "CompressedData = True\nCompressedDataSize = " + std::to_string(n) +
                   "\nTransformMatrix = 0 1 0 1 0 0 0 0 1\nPosition = 1 2 3\nElementSize = 0.5 0.25 2\n"
                   "DimSize = 4 3 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n" + z);
  // The matrix swaps the file's index axes 0 and 1 (index axis 0 runs along world y): the image
  // reads with its axes aligned to the world's, each voxel at the same world position.
  const Image<3> im = read_image<3>(path);
  EXPECT_EQ(im.size(), GridIndex<3>(ny, nx, nz));
  EXPECT_EQ(im.spacing(), Point<3>(0.25, 0.5, 2));
  EXPECT_EQ(im.origin(), Point<3>(1, 2, 3));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)  // file voxel (i, j, k) is world voxel (j, i, k)
        EXPECT_EQ(im.at(GridIndex<3>(j, i, k)), float(values[i + nx * (j + ny * k)])) << i << " " << j << " " << k;
}

// MET_LONG_LONG and MET_ULONG_LONG, big-endian raw and little-endian zlib: each value its nearest
// float (2^60 + 2^36 + 1 too, which rounding through double would put on 2^60).
TEST(ImageIo, MetaImage64BitIntegersReadAsTheirNearestFloat) {
  const std::string dir = fresh_dir();
  const int64_t tricky = (int64_t(1) << 60) + (int64_t(1) << 36) + 1;
  const std::vector<int64_t> s = {tricky, -3'000'000'000, std::numeric_limits<int64_t>::min(), -7};
  const std::vector<uint64_t> u = {uint64_t(tricky), (uint64_t(1) << 63) + (uint64_t(1) << 40),
                                   std::numeric_limits<uint64_t>::max(), 7};
  std::string big;
  for (const int64_t v : s)
    for (int b = 7; b >= 0; --b) big.push_back(char(uint64_t(v) >> (8 * b)));
  const std::string head = "ObjectType = Image\nNDims = 2\nBinaryData = True\nDimSize = 2 2\n";
  write_file(dir + "/s.mha", head + "BinaryDataByteOrderMSB = True\nElementType = MET_LONG_LONG\nElementDataFile = LOCAL\n" + big);
  uLongf n = compressBound(u.size() * 8);
  std::string z(n, '\0');
  ASSERT_EQ(compress(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(u.data()), u.size() * 8), Z_OK);
  z.resize(n);
  write_file(dir + "/u.mha", head + "CompressedData = True\nElementType = MET_ULONG_LONG\nElementDataFile = LOCAL\n" + z);
  const Image<2> si = read_image<2>(dir + "/s.mha"), ui = read_image<2>(dir + "/u.mha");
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(si[i], static_cast<float>(s[size_t(i)])) << i;
    EXPECT_EQ(ui[i], static_cast<float>(u[size_t(i)])) << i;
  }
  EXPECT_EQ(si[0], float(uint64_t(1) << 60) + float(uint64_t(1) << 37));
}

// MET_LONG and MET_ULONG hold 4 bytes in MetaIO (metaTypes.h), as MET_INT and MET_UINT do.
TEST(ImageIo, MetaImageLongIsFourBytes) {
  const std::string dir = fresh_dir();
  const std::vector<int32_t> s = {-2'000'000'000, -1, 0, 123456};
  const std::vector<uint32_t> u = {4'000'000'000u, 1, 0, 65537};
  std::string sb(reinterpret_cast<const char*>(s.data()), s.size() * 4);
  std::string ub(reinterpret_cast<const char*>(u.data()), u.size() * 4);
  const std::string head = "ObjectType = Image\nNDims = 2\nBinaryData = True\nDimSize = 2 2\n"
                           "BinaryDataByteOrderMSB = False\n";
  write_file(dir + "/s.mha", head + "ElementType = MET_LONG\nElementDataFile = LOCAL\n" + sb);
  write_file(dir + "/u.mha", head + "ElementType = MET_ULONG\nElementDataFile = LOCAL\n" + ub);
  const Image<2> si = read_image<2>(dir + "/s.mha"), ui = read_image<2>(dir + "/u.mha");
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(si[i], static_cast<float>(s[size_t(i)])) << i;
    EXPECT_EQ(ui[i], static_cast<float>(u[size_t(i)])) << i;
  }
  // Three values' bytes for four: refused, naming the file (the size follows from 4 bytes each).
  write_file(dir + "/short.mha", head + "ElementType = MET_LONG\nElementDataFile = LOCAL\n" + sb.substr(0, 12));
  EXPECT_THROW(read_image<2>(dir + "/short.mha"), InputError);
}

// Raw MetaImage data is read from its file a block at a time, the header from the file's first
// 64 kB: a volume of several blocks, HeaderSize skips (a count, and -1: the data are
// the file's last bytes), a header longer than 64 kB, and data shorter than declared (named
// with the bytes it holds) read right.
TEST(ImageIo, MetaImageRawDataIsReadFromItsFileAtTheRightPlace) {
  const std::string dir = fresh_dir();
  const int nx = 61, ny = 47, nz = 50;  // 143 350 int16 values: two blocks of stored values
  std::string raw;
  std::vector<float> values;
  for (int i = 0; i < nx * ny * nz; ++i) {
    const int16_t v = int16_t((i * 7919) % 60001 - 30000);
    values.push_back(v);
    raw.push_back(char(uint16_t(v) & 0xff));
    raw.push_back(char(uint16_t(v) >> 8));
  }
  const std::string head = "ObjectType = Image\nNDims = 3\nDimSize = 61 47 50\nElementType = MET_SHORT\n";
  write_file(dir + "/local.mha", head + "ElementDataFile = LOCAL\n" + raw);
  EXPECT_TRUE(read_image<3>(dir + "/local.mha").data() == values);
  write_file(dir + "/skip.raw", "12345" + raw + "tail");
  write_file(dir + "/skip.mhd", head + "HeaderSize = 5\nElementDataFile = skip.raw\n");
  EXPECT_TRUE(read_image<3>(dir + "/skip.mhd").data() == values);
  write_file(dir + "/end.raw", "a preamble" + raw);
  write_file(dir + "/end.mhd", head + "HeaderSize = -1\nElementDataFile = end.raw\n");
  EXPECT_TRUE(read_image<3>(dir + "/end.mhd").data() == values);
  std::string comments;  // 30 lines of 3000 characters: the header ends past 64 kB
  for (int i = 0; i < 30; ++i) comments += "Comment" + std::to_string(i) + " = " + std::string(3000, 'x') + "\n";
  write_file(dir + "/long.mha", head + comments + "ElementDataFile = LOCAL\n" + raw);
  EXPECT_TRUE(read_image<3>(dir + "/long.mha").data() == values);
  write_file(dir + "/short.mha", head + "ElementDataFile = LOCAL\n" + raw.substr(0, raw.size() - 3));
  expect_bad_file([](const std::string& p) { read_image<3>(p); }, dir + "/short.mha", "ElementDataFile",
                  "data holds " + std::to_string(raw.size() - 3) + " bytes, expected " + std::to_string(raw.size()));
}

TEST(ImageIo, Mha2dRoundTripAndSingleSliceVolumeReadsAs2d) {
  const std::string dir = fresh_dir();
  const Image<2> im = test_image_2d();
  write_image(im, dir + "/a.mha");
  EXPECT_EQ(image_file_dimension(dir + "/a.mha"), 2);
  expect_same_image(im, read_image<2>(dir + "/a.mha"));

  Grid<3> g;
  g.size = GridIndex<3>(7, 5, 1);
  g.spacing = Point<3>(0.3, 1.7, 9);
  g.origin = Point<3>(2.5, -1.25, 4);
  Image<3> slab(g);
  std::copy(im.data().begin(), im.data().end(), slab.data().begin());
  write_image(slab, dir + "/slab.mha");
  EXPECT_EQ(image_file_dimension(dir + "/slab.mha"), 2);
  expect_same_image(im, read_image<2>(dir + "/slab.mha"));
}

TEST(ImageIo, NiftiRoundTripKeepsSpacingAndOrigin) {
  const std::string dir = fresh_dir();
  const Image<3> im = test_volume();
  write_image(im, dir + "/v.nii");
  EXPECT_EQ(fs::file_size(dir + "/v.nii"), size_t(352 + im.num_voxels() * 4));
  EXPECT_EQ(image_file_dimension(dir + "/v.nii"), 3);
  expect_same_image(im, read_image<3>(dir + "/v.nii"), true);
}

TEST(ImageIo, NiftiGzRoundTripKeepsSpacingAndOrigin) {
  const std::string dir = fresh_dir(), path = dir + "/v.nii.gz";
  const Image<3> im = test_volume();
  write_image(im, path);
  const std::string bytes = read_file(path);
  ASSERT_GE(bytes.size(), 2u);
  EXPECT_EQ(uint8_t(bytes[0]), 0x1f);  // gzip magic
  EXPECT_EQ(uint8_t(bytes[1]), 0x8b);
  EXPECT_EQ(image_file_dimension(path), 3);
  expect_same_image(im, read_image<3>(path), true);
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"v.nii.gz"});
  write_image(test_image_2d(), dir + "/a.nii.gz");
  expect_same_image(test_image_2d(), read_image<2>(dir + "/a.nii.gz"), true);
}

// A volume that does not compress (noise: 1 MB of floats, whose gzip stream is longer than the
// 64 kB the compressor starts its output with, so that the output grows several times) comes
// back bit for bit, and its file holds one gzip stream of about the data's size.
TEST(ImageIo, NiftiGzOfIncompressibleNoiseRoundTrips) {
  const std::string dir = fresh_dir(), path = dir + "/noise.nii.gz";
  Grid<3> g;
  g.size = GridIndex<3>(64, 64, 64);
  Image<3> im(g);
  uint64_t state = 88172645463325252ull;
  for (int64_t l = 0; l < im.num_voxels(); ++l) {
    state ^= state << 13, state ^= state >> 7, state ^= state << 17;  // xorshift64
    uint32_t bits = uint32_t(state >> 32) & 0xbf7fffffu;  // finite: the exponent's top bit clear
    std::memcpy(&im[l], &bits, 4);
  }
  write_image(im, path);
  EXPECT_GT(fs::file_size(path), size_t(im.num_voxels()) * 4 * 9 / 10);
  const Image<3> back = read_image<3>(path);
  ASSERT_EQ(back.num_voxels(), im.num_voxels());
  EXPECT_EQ(std::memcmp(back.data().data(), im.data().data(), size_t(im.num_voxels()) * 4), 0);
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"noise.nii.gz"});
}

// A hand-made NIfTI-1 file: 3 x 2 x 2 voxels of `datatype`, little- or big-endian.
std::string nifti_by_hand(int16_t datatype, int16_t bitpix, float slope, float inter, const std::string& payload,
                          bool big_endian, int16_t qform_code = 0, int16_t sform_code = 1) {
  std::string h(352, '\0');
  auto put = [&](size_t off, auto value) {
    char b[sizeof(value)];
    std::memcpy(b, &value, sizeof(value));
    if (big_endian) std::reverse(b, b + sizeof(value));
    std::memcpy(h.data() + off, b, sizeof(value));
  };
  put(0, int32_t(348));
  const int16_t dim[8] = {3, 3, 2, 2, 1, 1, 1, 1};
  for (int i = 0; i < 8; ++i) put(40 + 2 * i, dim[i]);
  put(70, datatype);
  put(72, bitpix);
  const float pixdim[8] = {1, 0.5f, 0.75f, 2, 1, 1, 1, 1};
  for (int i = 0; i < 8; ++i) put(76 + 4 * i, pixdim[i]);
  put(108, 352.0f);
  put(112, slope);
  put(116, inter);
  put(252, qform_code);
  put(254, sform_code);
  // NIfTI's world is RAS: both transforms below are dsnake's (LPS) axis-aligned grid, the qform
  // as a half turn about z (quatern_d = 1), the sform as diag(-0.5, -0.75, 2).
  put(264, 1.0f);   // quatern_d
  put(268, -9.0f);  // qoffset_x, used only when qform_code > 0: LPS x = 9
  const float srow[3][4] = {{-0.5f, 0, 0, 4}, {0, -0.75f, 0, -5.5f}, {0, 0, 2, 6}};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) put(280 + 16 * r + 4 * c, srow[r][c]);
  std::memcpy(h.data() + 344, "n+1", 4);
  return h + payload;
}

TEST(ImageIo, NiftiAppliesSlopeAndInterceptToUint8AndInt16) {
  const std::string dir = fresh_dir();
  std::string u8, i16;
  for (int i = 0; i < 12; ++i) {
    u8.push_back(char(uint8_t(i * 20)));
    const int16_t v = int16_t(i * 1000 - 6000);
    i16.append(reinterpret_cast<const char*>(&v), 2);
  }
  write_file(dir + "/u8.nii", nifti_by_hand(2, 8, 2, 1, u8, false));
  write_file(dir + "/i16.nii", nifti_by_hand(4, 16, 2, 1, i16, false));
  const Image<3> a = read_image<3>(dir + "/u8.nii"), b = read_image<3>(dir + "/i16.nii");
  ASSERT_EQ(a.size(), GridIndex<3>(3, 2, 2));
  EXPECT_EQ(a.spacing(), Point<3>(0.5, 0.75, 2));
  EXPECT_EQ(a.origin(), Point<3>(-4, 5.5, 6));  // from srow_*[3] in LPS, since qform_code = 0
  for (int i = 0; i < 12; ++i) {
    EXPECT_EQ(a[i], float(2 * (i * 20) + 1)) << i;
    EXPECT_EQ(b[i], float(2 * (i * 1000 - 6000) + 1)) << i;
  }
}

// Scaled values are decoded a block of 65536 at a time (not all at once in double): a volume
// of several blocks, whose last one is partial, in .nii and .nii.gz, and a vector field whose
// components cross the blocks' borders, read right.
TEST(ImageIo, NiftiDecodesScaledVolumesAndVectorFieldsOfSeveralBlocks) {
  const std::string dir = fresh_dir();
  const int16_t nx = 61, ny = 47, nz = 53;  // 151951 voxels: two blocks and a partial third
  const int64_t n = int64_t(nx) * ny * nz;
  std::string payload;
  auto stored = [](int64_t i) { return int16_t(i * 7919 % 65536 - 32768); };
  for (int64_t i = 0; i < n; ++i) {
    const int16_t v = stored(i);
    payload.append(reinterpret_cast<const char*>(&v), 2);
  }
  std::string file = nifti_by_hand(4, 16, 0.5f, -1024.f, payload, false);
  const int16_t dim[4] = {3, nx, ny, nz};
  std::memcpy(file.data() + 40, dim, sizeof dim);
  write_file(dir + "/ct.nii", file);
  gzFile gz = gzopen((dir + "/ct.nii.gz").c_str(), "wb1");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, file.data(), unsigned(file.size())), int(file.size()));
  gzclose(gz);
  for (const std::string name : {"/ct.nii", "/ct.nii.gz"}) {
    SCOPED_TRACE(name);
    const Image<3> im = read_image<3>(dir + name);
    ASSERT_EQ(im.size(), GridIndex<3>(nx, ny, nz));
    int64_t wrong = 0;
    for (int64_t i = 0; i < n; ++i) wrong += im[i] != float(double(stored(i)) * 0.5 - 1024.0);
    EXPECT_EQ(wrong, 0);
  }
  Grid<3> g;
  g.size = GridIndex<3>(nx, ny, 8);  // 3 components of 22936 voxels: the first block ends in the third
  VectorField<3> f(g);
  for (int64_t i = 0; i < f.num_voxels(); ++i) f[i] = Point<3>(i, -0.5 * i, 0.25 * (i % 13));
  write_vector_field(f, dir + "/f.nii");
  EXPECT_EQ(read_vector_field<3>(dir + "/f.nii").data(), f.data());
}

// read_gz_bytes with the length a header gives: the same bytes as without it, whether the file
// holds exactly that, less or more, gzipped or not, within max_bytes.
TEST(ImageIo, ReadingWithAnExpectedLengthGivesTheFileAsItIs) {
  const std::string dir = fresh_dir();
  std::string content;
  for (int i = 0; i < 3'000'000; ++i) content.push_back(char(i * 131 % 251));
  write_file(dir + "/plain.bin", content);
  gzFile gz = gzopen((dir + "/packed.gz").c_str(), "wb1");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, content.data(), unsigned(content.size())), int(content.size()));
  gzclose(gz);
  for (const std::string name : {"/plain.bin", "/packed.gz"})
    for (const size_t expected : {size_t(0), size_t(1), size_t(1'000'000), content.size(), content.size() + 12345,
                                  size_t(1) << 40}) {
      SCOPED_TRACE(name + " expecting " + std::to_string(expected));
      EXPECT_TRUE(detail::read_gz_bytes(dir + name, std::string::npos, expected) == content);
      EXPECT_TRUE(detail::read_gz_bytes(dir + name, 2'500'000, expected) == content.substr(0, 2'500'000));
    }
  EXPECT_TRUE(detail::read_bytes(dir + "/plain.bin") == content);
  EXPECT_TRUE(detail::read_bytes(dir + "/plain.bin", 777) == content.substr(0, 777));
}

// inflate_values and inflate_file_values hand zlib its input and output a step at a time (zlib
// counts in 32 bits, so a stream over 4 GiB goes in 1 GiB steps) and decode the values as they
// come: with steps of a few bytes, both wrappers must give the values of the whole stream
// (values split across windows, after a skip that leaves them unaligned, both byte orders),
// stop at the count, give what a truncated stream holds, and name the key of corrupt data.
TEST(ImageIo, InflatingInStepsGivesTheValuesOfTheWholeStream) {
  const std::string dir = fresh_dir();
  std::string content;
  for (int i = 0; i < 200'000; ++i) content.push_back(char((i * 131 % 251) / 7));
  uLongf n = compressBound(content.size());
  std::string zlib_stream(n, '\0');
  ASSERT_EQ(compress2(reinterpret_cast<Bytef*>(zlib_stream.data()), &n, reinterpret_cast<const Bytef*>(content.data()),
                      content.size(), 6),
            Z_OK);
  zlib_stream.resize(n);
  const std::string gzip_stream = detail::gzip_bytes({content}, "test");
  // The gzip stream in a file after 11 bytes of something else, with 5 bytes after it.
  write_file(dir + "/stream.bin", "a header..." + gzip_stream + "after");
  using detail::Scalar;
  for (const Scalar type : {Scalar::kI16, Scalar::kF64, Scalar::kU8})
    for (const bool swap : {false, true})
      for (const size_t skip : {size_t(0), size_t(3)})
        for (const size_t step : {size_t(1), size_t(7), size_t(1) << 30}) {
          SCOPED_TRACE("type " + std::to_string(int(type)) + " swap " + std::to_string(swap) + " skip " +
                       std::to_string(skip) + " step " + std::to_string(step));
          const size_t nb = size_t(detail::scalar_bytes(type));
          const int64_t count = int64_t(content.size() - skip) / int64_t(nb) - 5;
          const std::vector<float> want = detail::decode<float>(content.data() + skip, count, type, swap);
          std::vector<float> got(17, 1.f);  // cleared first
          EXPECT_EQ(detail::inflate_values(zlib_stream, skip, count, type, swap, got, "f", "k", "zlib", step),
                    size_t(count) * nb);
          EXPECT_TRUE(got == want);
          got.assign(3, 2.f);
          EXPECT_EQ(detail::inflate_file_values(dir + "/stream.bin", 11, gzip_stream.size() + 5, skip, count, type, swap,
                                                got, "k", "gzip", step),
                    size_t(count) * nb);
          EXPECT_TRUE(got == want);
          // Truncated: half the stream, from memory and from the file.
          const size_t held = detail::inflate_values(std::string_view(gzip_stream).substr(0, gzip_stream.size() / 2),
                                                     skip, count, type, swap, got, "f", "k", "gzip", step);
          EXPECT_GT(held, 0u);
          EXPECT_LT(held, size_t(count) * nb);
          EXPECT_EQ(got.size(), held / nb);
          EXPECT_TRUE(std::equal(got.begin(), got.end(), want.begin()));
          EXPECT_EQ(detail::inflate_file_values(dir + "/stream.bin", 11, gzip_stream.size() / 2, skip, count, type,
                                                swap, got, "k", "gzip", step),
                    held);
          EXPECT_TRUE(std::equal(got.begin(), got.end(), want.begin()));
        }
  // More values asked for than the stream holds: all it holds; none asked for: none.
  std::vector<float> bytes;
  EXPECT_EQ(detail::inflate_values(zlib_stream, 0, int64_t(content.size()) + 999, Scalar::kU8, false, bytes, "f", "k",
                                   "zlib"),
            content.size());
  EXPECT_TRUE(bytes == detail::decode<float>(content.data(), int64_t(content.size()), Scalar::kU8, false));
  EXPECT_EQ(detail::inflate_values(zlib_stream, 0, 0, Scalar::kU8, false, bytes, "f", "k", "zlib"), 0u);
  EXPECT_TRUE(bytes.empty());
  std::string corrupt = zlib_stream;
  for (size_t i = corrupt.size() / 3; i < corrupt.size() / 3 + 40; ++i) corrupt[i] = char(~corrupt[i]);
  write_file(dir + "/corrupt.zraw", corrupt);
  for (const size_t step : {size_t(5), size_t(1) << 30}) {
    for (const bool from_file : {false, true}) {
      const InputError e = expect_input_error([&] {
        if (from_file)
          detail::inflate_file_values(dir + "/corrupt.zraw", 0, corrupt.size(), 0, int64_t(content.size()), Scalar::kU8,
                                      false, bytes, "CompressedData", "zlib", step);
        else
          detail::inflate_values(corrupt, 0, int64_t(content.size()), Scalar::kU8, false, bytes, "f.mha",
                                 "CompressedData", "zlib", step);
      });
      EXPECT_EQ(e.file(), from_file ? dir + "/corrupt.zraw" : "f.mha");
      EXPECT_EQ(e.where(), "CompressedData");
      EXPECT_TRUE(contains(e.what(), "corrupt zlib data")) << e.what();
    }
  }
}

TEST(ImageIo, NiftiReadsByteSwappedHeaderAndData) {
  const std::string dir = fresh_dir();
  std::string be;
  for (int i = 0; i < 12; ++i) {
    const uint16_t v = uint16_t(i * 5000);
    be.push_back(char(v >> 8));
    be.push_back(char(v & 0xff));
  }
  write_file(dir + "/be.nii", nifti_by_hand(512, 16, 0, 0, be, true, 1, 0));
  const Image<3> im = read_image<3>(dir + "/be.nii");
  EXPECT_EQ(im.spacing(), Point<3>(0.5, 0.75, 2));
  EXPECT_EQ(im.origin(), Point<3>(9, 0, 0));  // qoffset, since qform_code = 1
  for (int i = 0; i < 12; ++i) EXPECT_EQ(im[i], float(i * 5000)) << i;  // slope 0: no scaling
}

TEST(ImageIo, PngRoundTripOf8BitPattern) {
  const std::string dir = fresh_dir(), path = dir + "/p.png";
  Grid<2> g;
  g.size = GridIndex<2>(17, 9);
  Image<2> im(g);
  for (int64_t i = 0; i < im.num_voxels(); ++i) im[i] = float((i * 37 + i / 17 * 11) % 256);
  write_image(im, path);
  EXPECT_EQ(image_file_dimension(path), 2);
  expect_same_image(im, read_image<2>(path));
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"p.png"});

  // Values outside [0, 255] are clamped.
  im[0] = -40;
  im[1] = 300.4f;
  write_image(im, path);
  const Image<2> back = read_image<2>(path);
  EXPECT_EQ(back[0], 0.0f);
  EXPECT_EQ(back[1], 255.0f);
}

// The 2D raster reader converts the decoded pixels straight into the image's floats (no copy in
// double between them): 16-bit grey and 32-bit float pixels, on rows of odd length, come back
// exactly, in raster order.
TEST(ImageIo, RasterPixelsOfEveryDepthReadExactly) {
  const std::string dir = fresh_dir();
  cv::Mat wide(5, 7, CV_16UC1), real(5, 7, CV_32FC1);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) {
      wide.at<uint16_t>(y, x) = uint16_t(65535 - 977 * (x + 7 * y));
      real.at<float>(y, x) = -1.5e7f + 0.1f * float(x) + 1e-3f * float(y);
    }
  ASSERT_TRUE(write_raster(dir + "/wide.png", wide));
  ASSERT_TRUE(write_raster(dir + "/real.tif", real));
  const Image<2> a = read_image<2>(dir + "/wide.png"), b = read_image<2>(dir + "/real.tif");
  ASSERT_EQ(a.grid().size, GridIndex<2>(7, 5));
  ASSERT_EQ(b.grid().size, GridIndex<2>(7, 5));
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) {
      EXPECT_EQ(a.at({x, y}), float(wide.at<uint16_t>(y, x))) << x << " " << y;
      EXPECT_EQ(b.at({x, y}), real.at<float>(y, x)) << x << " " << y;
    }
}

TEST(ImageIo, VectorFieldRoundTrip2dAnd3d) {
  const std::string dir = fresh_dir();
  const Image<3> vol = test_volume();
  VectorField<3> f3(vol.grid());
  for (int64_t i = 0; i < f3.num_voxels(); ++i) f3[i] = Point<3>(vol[i], -0.5 * i, 0.25f * float(i % 7));
  const Image<2> im = test_image_2d();
  VectorField<2> f2(im.grid());
  for (int64_t i = 0; i < f2.num_voxels(); ++i) f2[i] = Point<2>(0.5 * i, -im[i]);
  for (const std::string ext : {".mha", ".nii", ".nii.gz"}) {
    SCOPED_TRACE(ext);
    const bool nifti = ext != ".mha";
    write_vector_field(f3, dir + "/f3" + ext);
    write_vector_field(f2, dir + "/f2" + ext);
    const VectorField<3> b3 = read_vector_field<3>(dir + "/f3" + ext);
    const VectorField<2> b2 = read_vector_field<2>(dir + "/f2" + ext);
    ASSERT_EQ(b3.grid().size, f3.grid().size);
    ASSERT_EQ(b2.grid().size, f2.grid().size);
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(b3.grid().spacing[k], nifti ? double(float(f3.grid().spacing[k])) : f3.grid().spacing[k]);
    EXPECT_EQ(b3.data(), f3.data());  // the values are float-representable
    EXPECT_EQ(b2.data(), f2.data());
    // A vector field is not a scalar image.
    const InputError e = expect_input_error([&] { read_image<3>(dir + "/f3" + ext); });
    EXPECT_TRUE(contains(e.what(), "component")) << e.what();
  }
}

TEST(ImageIo, MissingFileIsReportedWithItsName) {
  const std::string dir = fresh_dir();
  for (const std::string name : {"/none.mha", "/none.nii.gz", "/none.png"}) {
    const InputError e = expect_input_error([&] { read_image<2>(dir + name); });
    EXPECT_EQ(e.file(), dir + name);
    EXPECT_TRUE(contains(e.what(), "not found")) << e.what();
  }
  // An .mhd whose data file is missing names the data file.
  write_image(test_volume(), dir + "/v.mhd");
  fs::remove(dir + "/v.raw");
  const InputError e = expect_input_error([&] { read_image<3>(dir + "/v.mhd"); });
  EXPECT_EQ(e.file(), dir + "/v.raw");
  // A data file name longer than the system allows (found by fuzzing: not a raw
  // filesystem_error), a folder and a pipe in place of the image.
  write_file(dir + "/long.mha", "NDims = 2\nDimSize = 2 2\nElementType = MET_FLOAT\nElementDataFile = " +
                                    std::string(1000, 'x') + "\n");
  EXPECT_TRUE(contains(expect_input_error([&] { read_image<2>(dir + "/long.mha"); }).what(), "data file not found"));
  fs::create_directories(dir + "/folder.nii");
  EXPECT_TRUE(contains(expect_input_error([&] { read_image<3>(dir + "/folder.nii"); }).what(), "found a folder"));
  ASSERT_EQ(::mkfifo((dir + "/pipe.mha").c_str(), 0600), 0);
  EXPECT_TRUE(contains(expect_input_error([&] { read_image<3>(dir + "/pipe.mha"); }).what(), "found a pipe"));
}

TEST(ImageIo, TruncatedDataSaysHowManyBytes) {
  const std::string dir = fresh_dir();
  const Image<3> im = test_volume();
  const size_t expected = size_t(im.num_voxels()) * 4;
  write_image(im, dir + "/v.mha");
  std::string bytes = read_file(dir + "/v.mha");
  write_file(dir + "/v.mha", bytes.substr(0, bytes.size() - 10));
  InputError e = expect_input_error([&] { read_image<3>(dir + "/v.mha"); });
  EXPECT_EQ(e.file(), dir + "/v.mha");
  EXPECT_EQ(e.where(), "ElementDataFile");
  EXPECT_EQ(e.message(), "data holds " + std::to_string(expected - 10) + " bytes, expected " + std::to_string(expected));

  write_image(im, dir + "/v.nii");
  bytes = read_file(dir + "/v.nii");
  write_file(dir + "/v.nii", bytes.substr(0, bytes.size() - 4));
  e = expect_input_error([&] { read_image<3>(dir + "/v.nii"); });
  EXPECT_EQ(e.file(), dir + "/v.nii");
  EXPECT_TRUE(contains(e.message(), "expected " + std::to_string(expected))) << e.what();

  ImageWriteOptions zip;
  zip.compress = true;
  write_image(im, dir + "/z.mha", zip);
  bytes = read_file(dir + "/z.mha");
  write_file(dir + "/z.mha", bytes.substr(0, bytes.size() - 30));
  e = expect_input_error([&] { read_image<3>(dir + "/z.mha"); });
  EXPECT_EQ(e.file(), dir + "/z.mha");
}

// The values are streamed from the file: an offset past the file's end, however
// large (a float up to 3e38, found by fuzzing as undefined behaviour in the conversion to a byte
// count), and data cut short in a .nii.gz are refused with the header field and the byte counts.
TEST(ImageIo, NiftiOffsetPastTheEndAndShortGzipDataAreNamed) {
  const std::string dir = fresh_dir();
  std::string payload;
  for (int i = 0; i < 12; ++i) {
    const int16_t v = int16_t(i);
    payload.append(reinterpret_cast<const char*>(&v), 2);
  }
  for (const float offset : {377.f, 1e6f, 7.9e34f}) {  // the file ends at byte 376
    SCOPED_TRACE(offset);
    std::string file = nifti_by_hand(4, 16, 0, 0, payload, false);
    std::memcpy(file.data() + 108, &offset, 4);
    write_file(dir + "/far.nii", file);
    const InputError e = expect_input_error([&] { read_image<3>(dir + "/far.nii"); });
    EXPECT_EQ(e.where(), "vox_offset");
    EXPECT_TRUE(contains(e.message(), "lies outside the file")) << e.what();
  }
  const std::string file = nifti_by_hand(4, 16, 0, 0, payload.substr(0, 20), false);
  gzFile gz = gzopen((dir + "/short.nii.gz").c_str(), "wb1");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, file.data(), unsigned(file.size())), int(file.size()));
  gzclose(gz);
  const InputError e = expect_input_error([&] { read_image<3>(dir + "/short.nii.gz"); });
  EXPECT_EQ(e.where(), "vox_offset");
  EXPECT_EQ(e.message(), "data holds 20 bytes, expected 24");
}

// DimSize values each within bounds whose product overflows 64 bits (here to exactly 0 voxels)
// are refused by the memory limit, not read as an empty or small volume.
TEST(ImageIo, MetaImageSizesWhoseProductOverflowsAreRefused) {
  const std::string dir = fresh_dir(), path = dir + "/wrap.mha";
  write_file(path, "ObjectType = Image\nNDims = 3\nDimSize = 2097152 2097152 4194304\nElementType = MET_UCHAR\n"
                   "ElementDataFile = LOCAL\nabcd");
  const InputError e = expect_input_error([&] { read_image<3>(path); });
  EXPECT_EQ(e.file(), path);
  EXPECT_EQ(e.where(), "DimSize");
  EXPECT_TRUE(contains(e.message(), "memory limit")) << e.what();
}

// An offset inside the header would read its bytes as voxels: refused, as nibabel does. A plain
// .nii whose dims declare more values than any machine holds (here under a memory limit that lets
// them pass) is refused by its size before the values' room is allocated.
TEST(ImageIo, NiftiOffsetInsideTheHeaderAndDataBeyondTheFileAreRefused) {
  const std::string dir = fresh_dir();
  const std::string payload(12 * 2, '\0');
  for (const float offset : {0.f, 100.f, 348.f}) {
    SCOPED_TRACE(offset);
    std::string file = nifti_by_hand(4, 16, 0, 0, payload, false);
    std::memcpy(file.data() + 108, &offset, 4);
    write_file(dir + "/inside.nii", file);
    const InputError e = expect_input_error([&] { read_image<3>(dir + "/inside.nii"); });
    EXPECT_EQ(e.file(), dir + "/inside.nii");
    EXPECT_EQ(e.where(), "vox_offset");
    EXPECT_TRUE(contains(e.message(), "inside the header")) << e.what();
  }
  std::string file = nifti_by_hand(4, 16, 0, 0, payload, false);
  const int16_t dim[8] = {5, 32767, 32767, 32767, 1, 32767, 1, 1};
  std::memcpy(file.data() + 40, dim, sizeof dim);
  write_file(dir + "/wide.nii", file);
  ::setenv("DSNAKE_MAX_IMAGE_BYTES", "1e30", 1);
  const InputError e = expect_input_error([&] { convert_image_file(dir + "/wide.nii", dir + "/out.nii"); });
  ::unsetenv("DSNAKE_MAX_IMAGE_BYTES");
  EXPECT_EQ(e.file(), dir + "/wide.nii");
  EXPECT_EQ(e.where(), "vox_offset");
  EXPECT_TRUE(contains(e.message(), "data holds 24 bytes, expected ")) << e.what();
  EXPECT_FALSE(fs::exists(dir + "/out.nii"));
}

TEST(ImageIo, NanVoxelIsNamedByIndex) {
  const std::string dir = fresh_dir();
  Image<3> im = test_volume();
  im.at(GridIndex<3>(3, 2, 1)) = std::numeric_limits<float>::quiet_NaN();
  for (const std::string ext : {".mha", ".nii"}) {
    write_image(im, dir + "/v" + ext);
    const InputError e = expect_input_error([&] { read_image<3>(dir + "/v" + ext); });
    EXPECT_EQ(e.file(), dir + "/v" + ext);
    EXPECT_EQ(e.where(), "voxel (3, 2, 1)");
    EXPECT_TRUE(contains(e.message(), "NaN"));
  }
  im.at(GridIndex<3>(3, 2, 1)) = std::numeric_limits<float>::infinity();
  write_image(im, dir + "/inf.mha");
  const InputError e = expect_input_error([&] { read_image<3>(dir + "/inf.mha"); });
  EXPECT_TRUE(contains(e.message(), "infinite"));
}

// A non-finite voxel is named by its index in the file as stored (what nibabel and Slicer show),
// not by where the reader's reordering of a flipped axis puts it: a NIfTI whose sform runs x along
// RAS +x (LPS -x, read reversed) with a NaN at stored voxel (2, 1, 0) of 3 x 2 x 2.
TEST(ImageIo, NonFiniteVoxelIsNamedAsTheFileStoresIt) {
  const std::string dir = fresh_dir();
  std::vector<float> values(12, 1.0f);
  values[2 + 3 * 1] = std::numeric_limits<float>::quiet_NaN();
  std::string file = nifti_by_hand(16, 32, 0, 0, std::string(reinterpret_cast<const char*>(values.data()), 48), false);
  const float rx = 0.5f;  // srow_x[0]: +x in RAS
  std::memcpy(file.data() + 280, &rx, 4);
  write_file(dir + "/flipped.nii", file);
  expect_bad_file([](const std::string& p) { read_image<3>(p); }, dir + "/flipped.nii", "voxel (2, 1, 0)", "NaN");
  const InputError c = expect_input_error([&] { convert_image_file(dir + "/flipped.nii", dir + "/out.nrrd"); });
  EXPECT_EQ(c.where(), "voxel (2, 1, 0)");
  EXPECT_FALSE(fs::exists(dir + "/out.nrrd"));
}

TEST(ImageIo, WrongDimensionIsAnInputError) {
  const std::string dir = fresh_dir();
  write_image(test_image_2d(), dir + "/a.mha");
  write_image(test_image_2d(), dir + "/a.png");
  write_image(test_volume(), dir + "/v.nii");
  InputError e = expect_input_error([&] { read_image<3>(dir + "/a.mha"); });
  EXPECT_EQ(e.file(), dir + "/a.mha");
  EXPECT_EQ(e.where(), "NDims");
  EXPECT_EQ(e.message(), "expected a 3D image, found 2D");
  e = expect_input_error([&] { read_image<3>(dir + "/a.png"); });
  EXPECT_EQ(e.message(), "expected a 3D image, found 2D");
  e = expect_input_error([&] { read_image<2>(dir + "/v.nii"); });
  EXPECT_EQ(e.file(), dir + "/v.nii");
  EXPECT_EQ(e.message(), "expected a 2D image, found 3D");
  e = expect_input_error([&] { write_image(test_volume(), dir + "/v.png"); });
  EXPECT_EQ(e.file(), dir + "/v.png");
}

TEST(ImageIo, HeaderErrorsNameTheKey) {
  const std::string dir = fresh_dir(), path = dir + "/h.mha";
  const std::string good = "ObjectType = Image\nNDims = 2\nDimSize = 2 2\nElementSpacing = 1 1\n"
                           "ElementType = MET_UCHAR\nElementDataFile = LOCAL\nabcd";
  write_file(path, good);
  EXPECT_EQ(read_image<2>(path)[3], float('d'));
  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  const std::vector<std::array<std::string, 3>> cases = {
      {replace("DimSize = 2 2\n", ""), "DimSize", "missing required key"},
      {replace("MET_UCHAR", "MET_STRING"), "ElementType", "unsupported element type MET_STRING"},
      {replace("ElementSpacing = 1 1", "ElementSpacing = 1 0"), "ElementSpacing", "spacing must be positive"},
      {replace("NDims = 2", "NDims = 4"), "NDims", "unsupported dimension"},
      {replace("DimSize = 2 2", "DimSize = 2 x"), "DimSize", "expected numbers"},
      {replace("ElementDataFile = LOCAL\nabcd", ""), "ElementDataFile", "missing required key"},
      {"\x89PNG\r\n\x1a\n\x00\x00", "header line 1", "unreadable header"},
  };
  for (const auto& [text, key, part] : cases) {
    SCOPED_TRACE(key);
    write_file(path, text);
    const InputError e = expect_input_error([&] { read_image<2>(path); });
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.where(), key) << e.what();
    EXPECT_TRUE(contains(e.message(), part)) << e.what();
  }
  // NIfTI: an unsupported datatype (complex64 = 32) and a file too short for a header.
  write_file(dir + "/c.nii", nifti_by_hand(32, 64, 0, 0, std::string(12 * 8, '\0'), false));
  InputError e = expect_input_error([&] { read_image<3>(dir + "/c.nii"); });
  EXPECT_EQ(e.where(), "datatype");
  write_file(dir + "/s.nii", "short");
  e = expect_input_error([&] { read_image<3>(dir + "/s.nii"); });
  EXPECT_EQ(e.file(), dir + "/s.nii");
  e = expect_input_error([&] { read_image<3>(dir + "/v.xyz"); });
  EXPECT_TRUE(contains(e.message(), "unknown image format"));
}

}  // namespace
}  // namespace dsnake
