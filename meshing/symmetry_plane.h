// Symmetry planes normal to a world axis, of a label map or of an image: where a template's mirror
// image belongs (`dsnake template --mirror`, template_from_labels.h). A brain's mid-sagittal
// plane, for one, need not pass through the grid's centre (Colin27's is half a voxel off it).
//
// Both searches score candidate planes through voxel centres and through the faces between
// voxels (half-voxel steps), where every voxel's reflection is a voxel: no interpolation, so no
// bias towards planes that keep the samples aligned. A coarse search on a box-averaged copy (at
// most ~2^18 voxels) brackets the optimum, a search at full resolution finds the best step, and
// a fit through it and its two neighbours places the plane between steps (sub-voxel): a cone
// for the label map's counts of matching voxels (they fall linearly on both sides of the
// optimum), a parabola for the image's correlation.
#pragma once

#include "framework/core/image.h"

#include <utility>

namespace dsnake {

// The plane world[axis] = offset: axis 0 x, 1 y, 2 z (world axes, LPS), offset in mm.
struct MirrorPlane {
  int axis = 0;
  double offset = 0;
};

// p reflected about the plane: p[axis] -> 2 offset - p[axis].
template <int D>
Point<D> reflect(const Point<D>& p, const MirrorPlane& plane);

// The grid's extent along world axis `axis` (mm, low then high): the bounding box of its voxels
// (half a voxel beyond the outer centres).
template <int D>
std::pair<double, double> world_extent(const Grid<D>& grid, int axis);

// The plane normal to world `axis` that best maps the label map onto itself, each label onto its
// counterpart. Counterparts come from the data, not from label values (atlases number left and
// right structures differently, and a midline structure is its own): (1) the plane that maps the
// foreground (label != 0) best onto itself, by the overlap of the foreground with its reflection;
// (2) each label's counterpart, the non-zero label on which most of its reflected voxels fall
// there; (3) the plane maximising the number of labelled voxels whose reflection carries their
// label's counterpart, searched near (1). Candidate planes lie within the foreground's extent.
// Needs a grid whose axes run along the world's (the readers give one for any non-oblique image)
// and a non-empty foreground (checked: std::invalid_argument).
template <int D>
MirrorPlane label_symmetry_plane(const Image<D>& labels, int axis);

// The plane normal to world `axis` that best maps the image onto itself: the maximum of the
// normalised cross-correlation of the image with its reflection, over the voxels that both cover,
// among planes through the middle half of the grid along the axis (near the border, too few
// voxels overlap for the correlation to mean anything). Needs an axis-aligned grid at least 4
// voxels long along the axis, not constant (checked: std::invalid_argument).
template <int D>
MirrorPlane image_symmetry_plane(const Image<D>& image, int axis);

}  // namespace dsnake
