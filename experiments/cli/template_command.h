// `dsnake template`: a template from one label of a label image (meshing/template_from_labels.h):
//   dsnake template --mask LABELS --label N [--mirror x|y|z [--image IMAGE | --mirror-plane x=MM]]
//                   [--vertices 400] [--smoothing 10] [--allow-border] --out T.off
// 3D label volumes give a closed, outward triangle mesh (.off .obj .ply .stl .vtk), 2D label
// images a counter-clockwise closed contour (.txt .json .vtk). Prints one summary line (vertices,
// faces, genus, self-intersections, Dice against the label, what the mask clean-up changed, and
// the mirror plane). The command only configures the library: meshing/template_from_labels.h
// makes and mirrors the template, meshing/symmetry_plane.h finds the plane.
#pragma once

#include "framework/io/image_io.h"

#include <string>

namespace dsnake {

struct TemplateCommandOptions {
  std::string mask;          // --mask: the label image (2D or 3D; framework/io/image_io.h)
  int label = 1;             // --label N: the voxels == N
  std::string mirror;        // --mirror x|y|z: reflect about the symmetry plane normal to it ("" = none)
  std::string image;         // --image: the plane is the image's symmetry plane, not the label map's
  std::string mirror_plane;  // --mirror-plane AXIS=MM: the plane itself (world mm), no search
  int vertices = 400;        // --vertices: target count (3D within 10%, 2D exact)
  int smoothing = 10;        // --smoothing: Taubin λ|μ steps before decimation
  bool allow_border = false; // --allow-border: accept a label touching the image border
  std::string out;           // --out: mesh or contour file, by extension
  ImageReadOptions read;     // --nifti-transform: which NIfTI transform places the label map
};

// Runs the command; returns 0. Bad input throws InputError naming the file or option (exit 2);
// nothing is written then.
int run_template_command(const TemplateCommandOptions& options);

}  // namespace dsnake
