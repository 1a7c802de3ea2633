// `dsnake convert IN OUT`: copies an image or volume, a mesh or a contour from one file format
// to another, chosen by the extensions:
//   - images and volumes (2D, 3D, vector fields): .mha .mhd .nii .nii.gz .nrrd .nhdr .inr
//     .inr.gz, and for 2D .png .tif .tiff .jpg .jpeg .bmp; as input also a NIfTI pair .hdr/.img
//     (either file names it; .hdr.gz/.img.gz too); spacing, origin and direction are kept, the
//     voxels go through as float32 (8-bit grey for the 2D raster formats);
//   - meshes: .off .obj .ply .stl .vtk (POLYGONS), vertex order kept;
//   - contours: .txt .json .vtk (one LINES polyline), vertex order kept.
// A mesh to a volume format or any unknown extension is an InputError (exit code 2); nothing
// is written when reading or checking fails (the writers are atomic).
#pragma once

#include "framework/io/image_io.h"

#include <string>

namespace dsnake {

struct ConvertCommandOptions {
  std::string in;         // input file
  std::string out;        // output file
  ImageReadOptions read;  // --nifti-transform: which NIfTI transform places an image input
  bool compress = false;  // --compress: zlib MetaImage data, gzip NRRD encoding
};

// Runs the command; returns 0. Bad input throws InputError naming the file.
int run_convert_command(const ConvertCommandOptions& options);

}  // namespace dsnake
