// `dsnake init`: a complete experiment file for a user's own scan, with the recommended
// settings, printed on stdout:
//   dsnake init --image SCAN --template T [--reference ATLAS] [--mask GT] [--name NAME] > exp.json
// The settings are the recipe's, with only the inputs replaced: 2D with --reference
// experiments/real/recipe_2d_with_atlas.json, without it recipe_2d_without_atlas.json (the 3D
// recipes' settings in two dimensions); 3D with --reference recipe_3d.json (the atlas image
// registered onto the scan, then the patch force with ASAP-MLS), without it
// recipe_3d_without_atlas.json (the profile force with a local polarity per vertex, and one
// warning line that an atlas image is recommended). The project's
// real experiments run the same files (REPRODUCTION.md). Paths are written absolute. The file is checked by the experiment reader
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
