// The binary mask of one label of a label image, ready for surface extraction: label == N,
// reduced to its largest component, its cavities (holes in 2D) filled, padded by one empty voxel
// on every side so that an object touching the image border still gets a closed surface.
// Connectivity (documented in docs/real-scans.md, "dsnake template"): the object is 6-connected in 3D
// (4-connected in 2D), the background 26-connected (8-connected in 2D): two object voxels
// touching only along an edge or at a corner are apart, two such background voxels joined. The
// surface extraction (surface_extraction.h) makes the same choices, so the genus of the surface
// is the genus of the 6-connected object, and a cavity is background that cannot reach the
// padding through 26-neighbours.
#pragma once

#include "framework/core/image.h"

#include <cstdint>
#include <vector>

namespace dsnake {

// What extract_label_mask found and changed, for the summary line.
struct LabelMaskReport {
  int64_t label_voxels = 0;     // voxels == N in the image
  int components = 0;           // 6-connected (2D: 4-connected) components of those voxels
  int64_t kept_voxels = 0;      // voxels of the largest component
  int64_t filled_voxels = 0;    // background voxels enclosed by it (cavities, holes; other
                                // components inside them), now inside
  bool touches_border = false;  // the kept component has a voxel on the image border
};

template <int D>
struct LabelMask {
  Grid<D> grid;                // the image's grid grown by one voxel per side (origin - spacing)
  std::vector<uint8_t> inside; // 1 inside, 0 outside, per voxel of `grid` (x fastest)
  LabelMaskReport report;
};

// The mask of voxels == label (exact comparison: labels are integers stored as floats). Keeps
// the largest component (ties: the first in memory order) and fills what it encloses.
// Returns a mask with no inside voxel when no voxel has the label.
template <int D>
LabelMask<D> extract_label_mask(const Image<D>& labels, int label);

// Image of 1 where `labels` == label, 0 elsewhere, on the labels' grid (the reference for Dice).
template <int D>
Image<D> label_indicator(const Image<D>& labels, int label);

}  // namespace dsnake
