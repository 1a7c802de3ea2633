// Seeded image corruptions of the paper's robustness experiments (§8), applied in order:
//  - "outliers" {fraction p}: each voxel flips to the other grey level with probability p
//    (values nearer the minimum go to the maximum and vice versa; a binary image stays binary);
//  - "noise" {sigma}: additive white Gaussian noise, clamped to [0, 255];
//  - "perturb" {radius r}: every foreground voxel moves a random distance <= r (physical
//    units) in a random direction onto a background canvas; the image stays binary.
//    The foreground is the less frequent of the two extreme grey levels unless "foreground" is given.
#pragma once

#include "framework/image.h"
#include "framework/json_reader.h"

#include <cstdint>

namespace dsnake {

// Reads one corruption from `reader` and applies it. The random stream derives from the
// experiment seed and the corruption's position in the list only.
template <int D>
void apply_corruption(Image<D>& image, JsonReader& reader, uint64_t seed, int index);

}  // namespace dsnake
