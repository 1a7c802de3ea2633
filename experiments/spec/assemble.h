// Builds the objects of an experiment from its read sections (experiments/spec/experiment_spec.h):
// renders or reads the image and applies the corruptions, builds and places the template, sets
// the ground truth (a phantom's own, then files), builds the field, the energies and the phases.
// Problems that need the built objects (landmark ids beyond the template, an energy without a
// least-squares form in a global solve, a neighbourhood larger than the template) are
// InputErrors naming the file and the JSON path, as at reading.
#pragma once

#include "experiments/spec/experiment_spec.h"

namespace dsnake {

template <int D>
Experiment<D> assemble(const ExperimentSpec<D>& spec);

// A template smaller than a voxel has nothing to register at the image's resolution (the forces
// are sampled a voxel apart, §5.4), and its degenerate facets made the metrics' nearest facet
// search visit every facet for every sample. "" when `points` (the template as placed) span at
// least the smallest voxel of `grid` (their bounding box's diagonal); else the problem, e.g.
// "spans 0.52 mm, less than a voxel (0.8 mm): scale it to the object's size". `dsnake run` and
// `dsnake init` refuse it with the same words.
template <int D>
std::string smaller_than_a_voxel(const PointList<D>& points, const Grid<D>& grid);

// A template far from the image has nothing to register (one scaled by 1e200 ran, diverged and
// crashed): "" when every point lies within one image extent of the image's box (in continuous
// voxel indices); else the problem, e.g. "lies outside the image: vertex 0 is more than the
// image's extent beyond its border along axis 0". `dsnake run` and `dsnake init` refuse it with
// the same words.
template <int D>
std::string outside_the_image(const PointList<D>& points, const Grid<D>& grid);

}  // namespace dsnake
