// Registration metrics against a ground truth given as a mask and/or a surface, in physical
// units of the image, for a closed polygon (2D) or closed triangle mesh (3D):
//  - symmetric mean surface distance, HD95 and Hausdorff (surfaces sampled densely by area/length);
//  - Dice of the rasterised snake interior against the mask;
//  - correspondence error per template vertex against known target positions;
//  - the number of self-intersections (crossing non-adjacent edges in 2D, intersecting
//    non-adjacent triangles in 3D).
#pragma once

#include "framework/core/image.h"
#include "framework/core/shape.h"

#include <optional>
#include <vector>

namespace dsnake {

template <int D>
struct SurfaceRef {  // a closed polygon or mesh, by reference
  const PointList<D>& points;
  const Connectivity& connectivity;
};

template <int D>
struct GroundTruth {
  std::optional<Image<D>> mask;                   // non-zero = inside, any grid
  std::optional<Template<D>> surface;             // closed contour / mesh
  std::vector<std::optional<Point<D>>> targets;   // per template id; empty if unknown
};

struct SurfaceDistances {
  double mean = 0;       // symmetric: (mean d(A->B) + mean d(B->A)) / 2, area/length weighted
  double hausdorff95 = 0;  // 95th percentile of the pooled distances of both directions
  double hausdorff = 0;    // max of both directions
};

// Distances between two closed surfaces, sampled every `sample_spacing` (physical units) or
// finer; exact point-to-segment / point-to-triangle distances.
template <int D>
SurfaceDistances surface_distances(SurfaceRef<D> a, SurfaceRef<D> b, double sample_spacing);

// Exact distance from each point to the closed surface s (uniform-grid accelerated); the
// building block of surface_distances, exposed for tests and tools.
template <int D>
std::vector<double> distances_to_surface(SurfaceRef<D> s, const PointList<D>& points);

// Distances between a surface and the boundary of a mask (the faces between inside and
// outside voxels), for when the ground truth has a mask and no surface.
template <int D>
SurfaceDistances surface_distances_to_mask(SurfaceRef<D> a, const Image<D>& mask, double sample_spacing);

// 1 at voxel centres inside the closed surface, 0 outside, on `grid`.
template <int D>
Image<D> rasterize_interior(SurfaceRef<D> s, const Grid<D>& grid);

// Dice 2|A∩B|/(|A|+|B|) of two masks on the same grid (non-zero = inside); 1 if both are empty.
template <int D>
double dice(const Image<D>& a, const Image<D>& b);

struct CorrespondenceError {
  double mean = 0, max = 0;
  int count = 0;                   // template vertices with a target and a snake vertex
  std::vector<double> per_vertex;  // per template id; NaN where no target
};
template <int D>
CorrespondenceError correspondence_error(const Snake<D>& snake,
                                         const std::vector<std::optional<Point<D>>>& targets);

template <int D>
int count_self_intersections(SurfaceRef<D> s);

struct Metrics {
  std::optional<double> mean_surface_distance, hausdorff95, hausdorff, dice;
  std::optional<double> correspondence_error_mean, correspondence_error_max;
  int self_intersections = 0;
};

// All metrics the ground truth allows (absent ones stay empty). sample_spacing defaults to a
// fifth of the smallest voxel size of the mask when there is one, else 0.2.
template <int D>
Metrics compute_metrics(const Snake<D>& snake, const GroundTruth<D>& truth, double sample_spacing = 0);

}  // namespace dsnake
