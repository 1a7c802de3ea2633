// `dsnake init`: a complete experiment file for a user's own scan, with the recommended
// settings, printed on stdout:
//   dsnake init --image SCAN --template T [--reference ATLAS] [--mask GT] [--name NAME] > exp.json
// The settings are the recipe's, experiments/real/recipe_2d.json or recipe_3d.json (issue 20:
// a D-Snake with the profile force, the polarity rule, the field on the template's region and
// the windowed stop), with only the inputs replaced; the project's real experiments run the
// same files (REPRODUCTION.md). Paths are written absolute. The file is checked by the experiment reader
// before it is printed; nothing is printed on an error (exit code 2).
#pragma once

#include "framework/io/image_io.h"

#include <string>

namespace dsnake {

struct InitCommandOptions {
  std::string image;     // --image: 2D image or 3D volume (any format read_image reads)
  std::string tmpl;      // --template: 3D mesh (.off .obj .ply .stl .vtk) or 2D contour (.txt .json .vtk)
  std::string reference; // --reference: an image in which the template sits on its object (template.reference_image); "" = none
  std::string mask;      // --mask: ground truth, a label image (non-zero inside) or a surface file; "" = none
  std::string name;      // --name: the experiment's name ("" = the image's file name)
  ImageReadOptions read; // --nifti-transform: written as image.nifti_transform unless auto
};

// Prints the experiment file; returns 0. Bad input throws InputError naming it.
int run_init_command(const InitCommandOptions& options);

}  // namespace dsnake
