// Figure writers (PNG): a 2D image with shapes drawn over it, and three orthogonal slices of a
// volume with the cross-sections of meshes. The line plots (energy, convergence) and the 3D
// rendering are matplotlib's (scripts/figures/run_figures.py), drawn by `dsnake run`.
// As in the paper's figures (e.g. Fig. 12 of Levi & Gotsman, "D-Snake"), the template or the
// initial snake is drawn in yellow and the result in red; feature points are dots (green, Fig. 2).
//
// Display conventions: grey values are windowed from the image's min..max to black..white and
// shown nearest-neighbour, so voxels stay visible; each axis is scaled by its spacing, so the
// figure has the physical aspect ratio. 2D: the image's first axis runs to the right and its
// second axis runs DOWNWARDS (row = y index, as image files store it; in LPS world coordinates
// this is the radiological view, patient's left on the right, posterior down). 3D slices follow
// the radiological convention of LPS: axial x right (L), y down (P); coronal x right (L), z up
// (S); sagittal y right (P), z up (S); each panel's label names the slice's position in mm and
// its orientation (an oblique scan's panels are its grid's planes, labelled with the world point
// they pass through). Every PNG is written atomically.
#pragma once

#include "framework/core/image.h"
#include "framework/core/shape.h"
#include "framework/core/types.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace dsnake {

using Rgb = std::array<uint8_t, 3>;  // red, green, blue

inline constexpr Rgb kTemplateYellow{255, 220, 0};  // the template / initial snake
inline constexpr Rgb kResultRed{230, 20, 20};       // the registration result
inline constexpr Rgb kFeatureGreen{20, 200, 60};    // landmarks / feature points
inline constexpr Rgb kTruthCyan{0, 190, 255};       // the ground truth
inline constexpr Rgb kLinkGreen{60, 170, 90};       // correspondence: a template vertex to where it landed

// One shape drawn over an image. Borrows the positions and the connectivity: they must outlive
// the call that draws the layer.
template <int D>
struct ShapeLayer {
  const PointList<D>& points;            // n positions, physical units (same frame as the image)
  const Connectivity& connectivity;      // 2D: closed polygon in index order; 3D: triangles
  Rgb rgb = kResultRed;                  // line colour
  std::vector<int> marked_vertices = {};  // vertex indices drawn as filled dots
  std::string label = "";                // legend entry ("template", "D-Snake"); "" = none
  Rgb marker_rgb = kFeatureGreen;        // colour of the dots
};
using ShapeLayer2 = ShapeLayer<2>;
using ShapeLayer3 = ShapeLayer<3>;

// A region given as a mask (a ground truth's voxels) drawn as the outline of its inside: the
// mask is sampled at the voxel centres of the figure's image or slice (nearest mask voxel; the
// mask must be in the image's frame) and its boundary traced by marching squares, so the line
// runs half-way between inside and outside pixel centres. Borrows the mask.
template <int D>
struct MaskLayer {
  const BinaryMask<D>& mask;
  Rgb rgb = kTruthCyan;
  std::string label = "";  // legend entry; "" = none
};

// The image (upscaled by an integer factor so that its longer side has at least 512 px, then
// per axis by spacing) with each layer's closed polygon drawn antialiased, 2 px wide, in layer
// order (later layers on top). A legend is added below when a layer has a label, a title above
// when `title` is not empty. Throws std::runtime_error naming png_path if it cannot be written.
// Mask layers are drawn first, under the shapes. `links` (physical units) are drawn as thin
// (1 px) segments in kLinkGreen between the masks and the shapes, with the legend entry
// "correspondence" when there is one: each joins a template vertex to where it landed, the
// registration the paper's D-Snake is about (§1: every template vertex finds its counterpart).
void write_overlay_figure(const Image<2>& image, const std::vector<ShapeLayer2>& layers,
                          const std::string& png_path, const std::string& title = "",
                          const std::vector<MaskLayer<2>>& masks = {},
                          const std::vector<std::array<Point<2>, 2>>& links = {});

// Three orthogonal slices through the voxel nearest to `centre` (physical units), side by side:
// axial (z = const; x right, y down), coronal (y = const; x right, z down) and sagittal
// (x = const; y right, z down), all at the same pixels per mm. Each mesh's cross-section with
// the slice plane is drawn in its layer colour; marked vertices within half a voxel of the
// plane are dots. One grey window (the volume's min..max) serves all three slices.
void write_slice_figure(const Image<3>& volume, const std::vector<ShapeLayer3>& layers,
                        const Point<3>& centre, const std::string& png_path,
                        const std::string& title = "", const std::vector<MaskLayer<3>>& masks = {});

// The label above a slice panel of `grid` through voxel `slice`, the slice's normal being grid
// axis `normal` (2: axial, 1: coronal, 0: sagittal): the view's name, the slice's world
// coordinate and its orientation. On an oblique grid (turned against the world, Grid::direction)
// the panels are the grid's planes, not anatomical ones: the label names the grid axis and the
// world point (LPS mm) the slice passes through.
std::string slice_label(const Grid<3>& grid, const GridIndex<3>& slice, int normal);

}  // namespace dsnake
