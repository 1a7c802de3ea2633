// The recommended settings for a user's own scan (issue 20): experiments/real/recipe_2d.json and
// recipe_3d.json, compiled in (CMake reads the files at configure time), so that `dsnake init`
// writes exactly the files that the real experiments run and a user copies.
#pragma once

namespace dsnake {

// The recipe file's text for dimension 2 or 3.
const char* recipe_json(int dimension);

}  // namespace dsnake
