// The recommended settings for a user's own scan: experiments/real/recipe_2d_with_atlas.json and
// recipe_3d.json (with an atlas image), recipe_2d_without_atlas.json and
// recipe_3d_without_atlas.json (without), compiled in (CMake reads the files at configure time), so
// that `dsnake init` writes exactly the files that the real experiments run and a user copies.
#pragma once

namespace dsnake {

// The recipe file's text for dimension 2 or 3, with or without an atlas image.
const char* recipe_json(int dimension, bool with_atlas);

}  // namespace dsnake
