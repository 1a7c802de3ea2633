// `dsnake convert`; see convert_command.h.
#include "experiments/cli/convert_command.h"

#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace dsnake {

namespace {

enum class Kind { kVolume, kMesh, kContour, kVtk, kUnknown };

// Lower-case extension, with ".nii.gz", ".inr.gz", ".hdr.gz" and ".img.gz" kept whole.
std::string extension(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* two : {".nii.gz", ".inr.gz", ".hdr.gz", ".img.gz"})
    if (name.size() > 7 && name.ends_with(two)) return two;
  const size_t dot = name.rfind('.');
  return dot == std::string::npos ? "" : name.substr(dot);
}

// What a file holds, by its extension (.vtk holds a mesh or a contour; a NIfTI pair's .hdr and
// .img are read only: the image writer refuses them as an output).
Kind kind_of(const std::string& path) {
  const std::string e = extension(path);
  for (const char* v : {".mha", ".mhd", ".nii", ".nii.gz", ".hdr", ".img", ".hdr.gz", ".img.gz", ".nrrd", ".nhdr",
                        ".inr", ".inr.gz", ".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp"})
    if (e == v) return Kind::kVolume;
  if (e == ".off" || e == ".obj" || e == ".ply" || e == ".stl") return Kind::kMesh;
  if (e == ".txt" || e == ".json") return Kind::kContour;
  if (e == ".vtk") return Kind::kVtk;
  return is_dicom_input(path) ? Kind::kVolume : Kind::kUnknown;  // read only: a DICOM output is refused below
}

// A legacy VTK file's content: a mesh if it has POLYGONS, else a contour if it has LINES.
Kind vtk_content(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "file not found");
  bool lines = false;
  for (std::string word; in >> word;) {
    if (word == "POLYGONS") return Kind::kMesh;
    lines |= word == "LINES";
  }
  if (!lines) throw InputError(path, "", "a VTK file with neither POLYGONS (a mesh) nor LINES (a contour)");
  return Kind::kContour;
}

// What a kind is called in messages.
const char* name_of(Kind k) {
  return k == Kind::kVolume ? "an image or volume" : k == Kind::kMesh ? "a mesh" : "a contour";
}

}  // namespace

// Reads IN by its kind and writes it to OUT, after checking that OUT's format holds that kind.
int run_convert_command(const ConvertCommandOptions& o) {
  Kind in = kind_of(o.in);
  if (in == Kind::kUnknown)
    throw InputError(o.in, "",
                     "unknown format (expected an image/volume, mesh or contour extension; see dsnake convert --help)");
  Kind out = kind_of(o.out);
  if (out == Kind::kUnknown)
    throw InputError(o.out, "", "unknown output format (see dsnake convert --help)");
  if (in == Kind::kVtk) in = vtk_content(o.in);
  if (out == Kind::kVtk && in != Kind::kVolume) out = in;
  if (in != out)
    throw InputError(o.out, "", std::string("cannot convert ") + name_of(in) + " (" + o.in + ") to " + name_of(out) +
                                    " format");
  if (in == Kind::kVolume) {
    ImageWriteOptions w;
    w.compress = o.compress;
    convert_image_file(o.in, o.out, w, o.read);
  } else if (in == Kind::kMesh) {
    const Template<3> mesh = read_mesh_template(o.in);
    write_mesh(mesh.positions, mesh.connectivity, o.out);
  } else {
    const Template<2> contour = read_contour_template(o.in);
    write_contour(contour.positions, o.out);
  }
  return 0;
}

}  // namespace dsnake
