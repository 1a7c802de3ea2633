// `dsnake field`: computes one external field from an image file and writes it, for
// inspection and for figures:
//   dsnake field --image X --type gvf [--param mu=0.1 ...] [--field-cache DIR] --out field.mha
// The field (D components per voxel) goes to a MetaImage/NIfTI vector image; for a 2D image
// also a PNG of the image with the field's arrows drawn over it (grey window min..max,
// upscaled, physical aspect; arrows on a regular grid, the longest one grid-step long).
#pragma once

#include "framework/io/image_io.h"

#include <string>
#include <vector>

namespace dsnake {

// The rows under the 2D figure's image that keep the field's magnitude: a colour bar from 0 to |F|max.
inline constexpr int kFieldLegendPx = 64;

struct FieldCommandOptions {
  std::string image;                // --image: 2D or 3D image file (framework/io/image_io.h)
  std::string type = "gvf";         // --type: a field registry name
  std::vector<std::string> params;  // --param key=value (repeatable): the field's JSON keys;
                                    // the value is read as JSON (number, bool) or else a string
  std::string cache;                // --field-cache DIR: inserted as "cache" ("" = none)
  std::string out;                  // --out: .mha / .mhd / .nii / .nii.gz / .nrrd / .nhdr / .inr / .inr.gz
  ImageReadOptions read;            // --nifti-transform: which NIfTI transform places the image
  std::string png;                  // --png: 2D figure (kFieldLegendPx rows of magnitude legend under the image); "" = --out with its extension -> .png
  bool no_png = false;              // --no-png: skip the figure
};

// Runs the command; returns 0. Bad input (file, type, parameter) throws InputError naming it
// (the CLI turns that into exit code 2).
int run_field_command(const FieldCommandOptions& options);

}  // namespace dsnake
