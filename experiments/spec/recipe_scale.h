// The recipes' lengths for a structure smaller than those they were measured on. The recipes of
// experiments/real/ give their lengths in mm (patch and profile sizes, smoothing, the image
// init's region and levels, tolerances): the same at every voxel size and template resolution.
// They were chosen and measured on human anatomy (REPRODUCTION.md: structures whose equivalent
// sphere radius is 7.4 to 28 mm, and larger organs). On a structure of the same shape at half the
// size (another species' brain), the same mm see twice as much of it and its surroundings, and
// the registration is no longer the one measured; with every length halved it is the same run, up
// to rounding. So `dsnake init` scales a recipe's lengths by
//
//   k = min(1, r / kRecipeRadiusMm),   r = the template's equivalent radius (the sphere, or in 2D
//                                          the disc, of the template's volume or area),
//
// which keeps the measured settings for every structure at least as large as the smallest one
// they were measured on, and keeps a smaller one's settings in the same proportion to its size.
#pragma once

#include "framework/core/shape.h"

#include <nlohmann/json.hpp>

namespace dsnake {

// The equivalent radius (mm) of the smallest structure the recipes were measured on (the
// amygdala of the anatomy development set, 7.4 mm), rounded down.
inline constexpr double kRecipeRadiusMm = 7.0;

// The radius of the sphere (3D) or disc (2D) of the template's enclosed volume or area, in the
// template's units; 0 for a template enclosing nothing.
template <int D>
double equivalent_radius(const Template<D>& t);

// k above for a template of equivalent radius r: min(1, r / kRecipeRadiusMm) to 3 significant
// digits (so that the printed lengths read), and 1 for r <= 0 (nothing to measure the structure
// by).
double recipe_length_scale(double equivalent_radius_mm);

// Multiplies the lengths of an experiment's settings by k: in "field" (and its "region"), every
// "energies[i]", "template.init" and every "phases[k]" (and its "remesh" stages), each key whose
// unit is mm (to 6 significant digits). A length the object leaves at its default is written out
// scaled, unless the default
// is 0 (which means "from the voxel size" or "off" wherever a length defaults to it). Left as
// they are: keys whose unit is not plainly mm (the tension's alpha and the external step tau,
// whose units depend on another key; the GVF's mu, which with a normalised edge map needs no
// scaling), points in world coordinates, the success thresholds and the metrics. `experiment`
// must be valid (its types registered for `dimension`).
void scale_lengths(nlohmann::ordered_json& experiment, int dimension, double k);

// The largest voxel side (mm, at the recipe's scale: h / k) the recipes were measured on.
inline constexpr double kRecipeMaxVoxelMm = 3.0;

// For a scan whose voxels are coarser than the recipe's (largest side h mm, h / k above
// kRecipeMaxVoxelMm): every patch energy whose smoothing sigma is below h / 4 gets its sigma,
// radius and sample spacing multiplied by f = h / (4 sigma), to 3 significant digits (a default
// written out; a 0 spacing, "the image's smallest voxel", kept). A patch finer than the slices
// compares the atlas's detail across a slice with the scan's interpolation between two: on
// 4 and 5 mm slices the recipe's refine phase (sigma 0.5 mm) then walked the fit off its
// boundary, and with sigma h / 4 it held it (REPRODUCTION.md, "Other acquisitions"). The other
// lengths stay as measured (the image init and the coarse patches see the structure, not the
// voxels). Returns the largest f applied (1: none). `experiment` must be valid.
double coarsen_patches_to_voxels(nlohmann::ordered_json& experiment, int dimension, double h);

}  // namespace dsnake
