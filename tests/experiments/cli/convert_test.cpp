// `dsnake convert IN OUT`: volumes between every format (geometry kept, values as float32),
// meshes and contours between theirs (vertex order kept), and bad input: exit code 2, one line
// on stderr naming the file and the field, and no output file.
#include "framework/io/image_io.h"
#include "framework/io/image_io_detail.h"
#include "framework/io/mesh_io.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

const std::string kScans = DSNAKE_SCANS_DIR;

struct CommandResult {
  int exit_code = -1;
  std::string err;
};

class ConvertTest : public test_support::TempDirTest {
 protected:
  CommandResult convert(const std::string& in, const std::string& out, const std::string& extra = "") {
    const std::string err = (dir_ / "stderr.txt").string();
    const std::string cmd = std::string(DSNAKE_EXE) + " convert " + in + " " + out + " " + extra + " >/dev/null 2>" + err;
    const int status = std::system(cmd.c_str());
    CommandResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.err = slurp(err);
    return r;
  }
  std::string at(const std::string& name) const { return (dir_ / name).string(); }
  // The bad-input contract: exit 2, one line naming every fragment, `out` not written.
  void expect_refused(const std::string& in, const std::string& out, const std::vector<std::string>& fragments) {
    SCOPED_TRACE(in + " -> " + out);
    const CommandResult r = convert(in, out);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const auto& f : fragments) EXPECT_NE(r.err.find(f), std::string::npos) << "missing \"" << f << "\" in: " << r.err;
    EXPECT_FALSE(fs::exists(out)) << "the output was written";
  }
};

// ITK's .nhdr through every 2D-capable volume format and back gives the same grid and voxels.
TEST_F(ConvertTest, ImageThroughEveryFormatKeepsGeometryAndVoxels) {
  const std::string src = kScans + "/itk/BrainProtonDensitySliceBorder20.nhdr";
  const Image<2> want = read_image<2>(src);
  std::string prev = src;
  for (const char* name : {"a.mha", "b.nii.gz", "c.nrrd", "d.inr", "e.mhd", "f.nhdr", "g.nii", "h.inr.gz", "i.png"}) {
    SCOPED_TRACE(name);
    const CommandResult r = convert(prev, at(name), "--compress");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const Image<2> got = read_image<2>(at(name));
    ASSERT_EQ(got.size(), want.size());
    EXPECT_EQ(got.data(), want.data());  // 8-bit values survive float32 and PNG
    if (std::string(name) != "i.png") {
      EXPECT_TRUE(got.grid().same_geometry(want.grid(), 0));
    }
    prev = at(name);
  }
}

// A 3D float volume with anisotropic spacing (CGAL's skull_2.9.inr) through NRRD, NIfTI and
// MetaImage; an oblique 2D direction (ITK's +30 degree .nhdr) is kept by the NRRD writer.
TEST_F(ConvertTest, VolumeKeepsSpacingOriginAndDirection) {
  const std::string src = kScans + "/cgal/images/skull_2.9.inr";
  const Image<3> skull = read_image<3>(src);
  ASSERT_EQ(convert(src, at("s.nrrd"), "--compress").exit_code, 0);
  ASSERT_EQ(convert(at("s.nrrd"), at("s.nii")).exit_code, 0);
  ASSERT_EQ(convert(at("s.nii"), at("s.mha")).exit_code, 0);
  const Image<3> back = read_image<3>(at("s.mha"));
  EXPECT_NEAR(back.spacing()[0], 3.943050, 1e-6);  // NIfTI stores float32 spacing
  EXPECT_NEAR(back.spacing()[2], 3.650790, 1e-6);
  EXPECT_TRUE(back.grid().same_geometry(skull.grid(), 1e-6));
  EXPECT_EQ(back.data(), skull.data());
  EXPECT_TRUE(read_image<3>(at("s.nrrd")).grid().same_geometry(skull.grid(), 0));

  ASSERT_EQ(convert(kScans + "/itk/BrainProtonDensitySliceBorder20DirectionPlus30.nhdr", at("r.nrrd")).exit_code, 0);
  const detail::RawVolume r = detail::read_nrrd(at("r.nrrd"));
  EXPECT_NEAR(r.axes[0][0], 0.8660254, 1e-6);
  EXPECT_NEAR(r.axes[0][1], 0.5, 1e-6);
  EXPECT_NEAR(r.axes[1][0], -0.5, 1e-6);
  EXPECT_NEAR(r.axes[1][1], 0.8660254, 1e-6);
}

TEST_F(ConvertTest, MeshAndContourKeepVertexOrder) {
  const std::string femur = kScans + "/cgal/meshes/femur.off";
  const Template<3> want = read_mesh_template(femur);
  std::string prev = femur;
  for (const char* name : {"f.ply", "f.vtk", "f.obj", "g.off"}) {
    SCOPED_TRACE(name);
    const CommandResult r = convert(prev, at(name));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    prev = at(name);
    const Template<3> got = read_mesh_template(at(name));
    ASSERT_EQ(got.num_vertices(), want.num_vertices());
    for (int v = 0; v < want.num_vertices(); ++v) ASSERT_LT((got.positions[v] - want.positions[v]).norm(), 1e-5) << v;
  }
  // STL stores triangles, not a vertex list: only the vertex count is kept
  ASSERT_EQ(convert(femur, at("f.stl")).exit_code, 0);
  EXPECT_EQ(read_mesh_template(at("f.stl")).num_vertices(), want.num_vertices());
  PointList<2> square = {{0, 0}, {2, 0}, {2, 1.5}, {0.25, 1}};
  write_contour(square, at("c.txt"));
  ASSERT_EQ(convert(at("c.txt"), at("c.json")).exit_code, 0);
  ASSERT_EQ(convert(at("c.json"), at("c.vtk")).exit_code, 0);
  ASSERT_EQ(convert(at("c.vtk"), at("d.txt")).exit_code, 0);
  const Template<2> c = read_contour_template(at("d.txt"));
  ASSERT_EQ(c.num_vertices(), 4);
  for (int v = 0; v < 4; ++v) EXPECT_EQ(c.positions[v], square[v]) << v;
}

TEST_F(ConvertTest, BadInputExitsTwoWithOneLineAndNoOutput) {
  std::ofstream(at("bad.nrrd"), std::ios::binary) << "NRRD0004\ntype: float\ndimension: 3\nsizes: 100 100 100\n"
                                                     "endian: little\nencoding: raw\n\n0123456789";
  expect_refused(at("bad.nrrd"), at("out.mha"), {"bad.nrrd", "sizes"});
  std::ofstream(at("huge.inr"), std::ios::binary) << "#INRIMAGE-4#{\nXDIM=1000000\nYDIM=1000000\nZDIM=1000000\n"
                                                     "TYPE=float\nPIXSIZE=32 bits\n##}\n";
  expect_refused(at("huge.inr"), at("out.nrrd"), {"huge.inr", "XDIM"});
  std::ofstream(at("nodata.nhdr")) << "NRRD0004\ntype: uchar\ndimension: 2\nsizes: 2 2\nencoding: raw\ndata file: gone.raw\n";
  expect_refused(at("nodata.nhdr"), at("out.nii"), {"nodata.nhdr", "data file", "gone.raw"});
  expect_refused(kScans + "/cgal/meshes/femur.off", at("out.mha"), {"out.mha", "mesh"});
  expect_refused(kScans + "/cgal/images/liver.inr.gz", at("out.ply"), {"out.ply", "mesh"});
  expect_refused(kScans + "/cgal/images/liver.inr.gz", at("out.xyz"), {"out.xyz", "unknown"});
  expect_refused(at("in.abc"), at("out.mha"), {"in.abc", "unknown"});
  expect_refused(at("missing.nrrd"), at("out.mha"), {"missing.nrrd", "not found"});
}

// Limits from headers: a header's sizes are checked against what the file can hold
// and the memory limit before anything is allocated or inflated; library messages do not reach
// stderr; each case is one line naming the file and the header key.
TEST_F(ConvertTest, HeadersAreCheckedBeforeAnyAllocation) {
  auto deflate = [](const std::string& raw) {
    uLongf n = compressBound(raw.size());
    std::string z(n, '\0');
    compress2(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(raw.data()), raw.size(), 9);
    z.resize(n);
    return z;
  };
  const std::string z = deflate(std::string(1 << 20, '\0'));
  auto meta = [&](const std::string& dims) {
    return "ObjectType = Image\nNDims = 3\nDimSize = " + dims + "\nElementType = MET_FLOAT\nCompressedData = True\n"
           "CompressedDataSize = " + std::to_string(z.size()) + "\nElementDataFile = LOCAL\n" + z;
  };
  // 4 GB claimed from 1 kB of deflate data: more than deflate can expand to
  std::ofstream(at("bomb.mha"), std::ios::binary) << meta("1024 1024 1024");
  expect_refused(at("bomb.mha"), at("out.nrrd"), {"bomb.mha", "CompressedData", "deflate"});
  // 34 GB as float: above the memory limit (here set to 100 MB)
  std::ofstream(at("big.mha"), std::ios::binary) << meta("2048 2048 2048");
  ::setenv("DSNAKE_MAX_IMAGE_BYTES", "100000000", 1);
  expect_refused(at("big.mha"), at("out.nrrd"), {"big.mha", "DimSize", "memory limit"});
  ::unsetenv("DSNAKE_MAX_IMAGE_BYTES");
  // PLY: 2e9 vertices declared in a 200-byte file; garbage after a valid header: one line, ours
  std::ofstream(at("huge.ply")) << "ply\nformat ascii 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\n"
                                   "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n";
  expect_refused(at("huge.ply"), at("out.off"), {"huge.ply", "element vertex", "2000000000"});
  std::ofstream(at("garbage.ply"), std::ios::binary) << "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                                                        "property float x\nend_header\n\x01\x02";
  expect_refused(at("garbage.ply"), at("out.off"), {"garbage.ply"});
  // Found by fuzzing: a PLY header without end_header (OpenMesh's reader never returned) and a
  // header line that is not PLY; DICOM bytes in a .png (OpenCV handed them to GDCM, which aborted).
  std::ofstream(at("noend.ply")) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                    "property float-1 0 0\n0 1 0\n3 0 2 4\n";
  expect_refused(at("noend.ply"), at("out.off"), {"noend.ply", "header line 6", "property TYPE NAME"});
  std::ofstream(at("open.ply")) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n";
  expect_refused(at("open.ply"), at("out.off"), {"open.ply", "no 'end_header' line"});
  std::ofstream(at("badtype.ply")) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n1\n";
  expect_refused(at("badtype.ply"), at("out.off"), {"badtype.ply", "header line 4", "property TYPE NAME"});
  std::ofstream(at("dicom.png"), std::ios::binary) << "NT" + std::string(126, '\2') + "DICMID";
  expect_refused(at("dicom.png"), at("out.nrrd"), {"dicom.png", "not PNG, JPEG, BMP or TIFF"});
  // More fuzzing findings, replayed from the corpus: a BMP declaring 8 388 612 columns (OpenCV's
  // exception), an OBJ whose only content on a line is a vertical tab (an empty word list was
  // indexed), and OFF/OBJ/VTK counts and references of 1e300 (converted to int before any check).
  const std::string corpus = std::string(DSNAKE_SOURCE_DIR) + "/tests/fuzz/corpus/";
  fs::copy_file(corpus + "raster/crash_bmp_huge_width", at("wide.bmp"));
  expect_refused(at("wide.bmp"), at("out.nrrd"), {"wide.bmp", "cannot decode the image (OpenCV"});
  fs::copy_file(corpus + "mesh/crash_obj_vertical_tab_line", at("vt.obj"));
  expect_refused(at("vt.obj"), at("out.off"), {"vt.obj", "empty template"});
  fs::copy_file(corpus + "mesh/crash_ply_ascii_short_face_line", at("short.ply"));
  expect_refused(at("short.ply"), at("out.off"), {"short.ply", "line 17", "does not match the header's 'face' properties"});
  fs::copy_file(corpus + "mesh/crash_ply_bad_format_version", at("version.ply"));
  expect_refused(at("version.ply"), at("out.off"), {"version.ply", "header line 2", "1.0'"});
  fs::copy_file(corpus + "mesh/crash_ply_huge_other_element", at("other.ply"));
  expect_refused(at("other.ply"), at("out.off"), {"other.ply", "element vert1x", "more than the file's"});
  std::ofstream(at("novertex.ply")) << "ply\nformat ascii 1.0\nend_header\n";
  expect_refused(at("novertex.ply"), at("out.off"), {"novertex.ply", "no 'element vertex' line"});
  // ... while a well-formed ASCII PLY with comments, colours and a blank line still reads
  std::ofstream(at("ok.ply")) << "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 4\nproperty float x\n"
                                 "property float y\nproperty float z\nproperty uchar red\nelement face 4\n"
                                 "property list uchar int vertex_indices\nend_header\n0 0 0 255\n1 0 0 0\n\n0 1 0 0\n"
                                 "0 0 1 9\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  EXPECT_EQ(convert(at("ok.ply"), at("ok.off")).exit_code, 0);
  EXPECT_TRUE(fs::exists(at("ok.off")));
  std::ofstream(at("big.off")) << "OFF\n1e300 1 0\n0 0 0\n3 0 0 0\n";
  expect_refused(at("big.off"), at("out.obj"), {"big.off", "unexpected end of file"});
  std::ofstream(at("far.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1e300\n";
  expect_refused(at("far.obj"), at("out.off"), {"far.obj", "line 4", "out of range"});
  std::ofstream(at("big.vtk")) << "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 1e300 double\n"
                                  "POLYGONS 1 4\n3 0 1 2\n";
  expect_refused(at("big.vtk"), at("out.off"), {"big.vtk", "POINTS", "larger than the file"});
  // A truncated PNG: libpng's own line is not printed
  const std::string png = slurp(std::string(DSNAKE_SOURCE_DIR) + "/docs/figures/real/lung.png");
  ASSERT_GT(png.size(), 1000u);
  std::ofstream(at("cut.png"), std::ios::binary) << png.substr(0, png.size() / 3);
  expect_refused(at("cut.png"), at("out.nrrd"), {"cut.png", "cannot decode"});
  // A gzipped INR whose header claims more than its deflate data can give
  {
    std::string header = "#INRIMAGE-4#{\nXDIM=2000\nYDIM=2000\nZDIM=500\nTYPE=float\nPIXSIZE=32 bits\nCPU=decm\n";
    header += std::string(256 - header.size() - 4, '\n') + "##}\n";
    gzFile f = gzopen(at("bomb.inr.gz").c_str(), "wb");
    gzwrite(f, header.data(), unsigned(header.size()));
    gzclose(f);
    expect_refused(at("bomb.inr.gz"), at("out.nrrd"), {"bomb.inr.gz", "XDIM", "deflate"});
  }
}

}  // namespace
}  // namespace dsnake
