// `dsnake init`: a complete experiment file for a user's own scan, with the recommended
// settings, printed on stdout:
//   dsnake init --image SCAN --template T [--mask GT] [--name NAME] > exp.json
// The settings follow the project's D-Snake recipe (internal + external + approximate ASAP-MLS
// over 2 rings, §3; a GVF field; a fit phase, then a refine phase that remeshes), with every
// length derived from the image's voxel size and the template's edge length (the rules are in
// init_command.cpp and in the file's "description"), so that the same command means the same
// at any resolution. Paths are written absolute. The file is checked by the experiment reader
// before it is printed; nothing is printed on an error (exit code 2).
#pragma once

#include <string>

namespace dsnake {

struct InitCommandOptions {
  std::string image;     // --image: 2D image or 3D volume (any format read_image reads)
  std::string tmpl;      // --template: 3D mesh (.off .obj .ply .stl .vtk) or 2D contour (.txt .json .vtk)
  std::string mask;      // --mask: ground truth, a label image (non-zero inside) or a surface file; "" = none
  std::string name;      // --name: the experiment's name ("" = the image's file name)
};

// Prints the experiment file; returns 0. Bad input throws InputError naming it.
int run_init_command(const InitCommandOptions& options);

}  // namespace dsnake
