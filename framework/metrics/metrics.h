// Registration metrics against a ground truth given as a mask and/or a surface, in physical
// units of the image, for a closed polygon (2D) or closed triangle mesh (3D):
//  - symmetric mean surface distance, HD95 and Hausdorff (surfaces sampled densely by area/length);
//  - Dice of the rasterised snake interior against the mask;
//  - correspondence error per template vertex against known target positions;
//  - the number of self-intersections (crossing non-adjacent edges in 2D, intersecting
//    non-adjacent triangles in 3D).
#pragma once

#include "framework/core/image.h"
#include "framework/core/options.h"
#include "framework/core/shape.h"

#include <cstdint>
#include <functional>
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
  std::optional<BinaryMask<D>> mask;              // any grid (from an image: non-zero = inside)
  std::optional<Template<D>> surface;             // closed contour / mesh
  std::vector<std::optional<Point<D>>> targets;   // per template id; empty if unknown
};

struct SurfaceDistances {
  double mean = 0;       // symmetric: (mean d(A->B) + mean d(B->A)) / 2, area/length weighted
  double hausdorff95 = 0;  // 95th percentile of the pooled distances of both directions
  double hausdorff = 0;    // max of both directions
};

// Distances between two closed surfaces, sampled every `sample_spacing` (physical units) or
// finer, each surface at most `max_samples` times (then coarser); exact point-to-segment /
// point-to-triangle distances.
template <int D>
SurfaceDistances surface_distances(SurfaceRef<D> a, SurfaceRef<D> b, double sample_spacing,
                                   int64_t max_samples = INT64_MAX);

// Exact distance from each point to the closed surface s (uniform-grid accelerated); the
// building block of surface_distances, exposed for tests and tools.
template <int D>
std::vector<double> distances_to_surface(SurfaceRef<D> s, const PointList<D>& points);

// Distances between a surface and the boundary of a mask (the faces between inside and
// outside voxels), for when the ground truth has a mask and no surface.
template <int D>
SurfaceDistances surface_distances_to_mask(SurfaceRef<D> a, const BinaryMask<D>& mask, double sample_spacing,
                                           int64_t max_samples = INT64_MAX);
// The same with the mask given as an image (non-zero = inside).
template <int D>
SurfaceDistances surface_distances_to_mask(SurfaceRef<D> a, const Image<D>& mask, double sample_spacing,
                                           int64_t max_samples = INT64_MAX);

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

// "metrics": how finely the surfaces are sampled for the surface distances (a cost
// bounded by a count, whatever the grid's size or the mesh's state). Each surface is sampled
// every `sample_spacing` mm, or more coarsely where that would give it more than `max_samples`
// samples: its spacing then grows to the smallest that fits. Dice is exact (the interior is
// rasterised on the box of the mask's and the snake's voxels only).
struct MetricsOptions {
  double sample_spacing = 0;  // mm; 0: a fifth of the mask's smallest voxel (0.2 mm without a mask)
  int max_samples = 1000000;  // per surface

  template <class V>
  void visit(V& v) {
    v(sample_spacing, Key{"sample_spacing", "mm",
                          "the finest spacing of the surface samples of the distances (0: a fifth of the ground-truth "
                          "mask's smallest voxel, 0.2 mm without a mask)",
                          Range::at_least(0)});
    v(max_samples, Key{"max_samples", "samples",
                       "the most samples per surface: a surface that would have more at sample_spacing is sampled "
                       "more coarsely (bounds the metrics' time and memory on large grids and runaway meshes)",
                       Range::closed(1000, 1e9)});
  }
};

struct Metrics {
  std::optional<double> mean_surface_distance, hausdorff95, hausdorff, dice;
  std::optional<double> correspondence_error_mean, correspondence_error_max;
  int self_intersections = 0;
};

// The spacing at which a surface is sampled: `finest`, or the smallest larger spacing at which
// count(spacing) <= max_samples (count is non-increasing; bisection to 1e-3 relative), or
// `coarsest`, the spacing at which every facet is down to one sample (count no longer falls
// beyond it), when even that is too many.
double bounded_spacing(double finest, double coarsest, int64_t max_samples,
                       const std::function<int64_t(double)>& count);

// Dice of the snake's interior against the mask, exactly as dice(rasterize_interior(s, grid),
// mask), computed on the box of voxels that holds both (cost follows the object, not the grid).
template <int D>
double dice_against_mask(SurfaceRef<D> s, const BinaryMask<D>& mask);
template <int D>
double dice_against_mask(SurfaceRef<D> s, const Image<D>& mask);

// All metrics the ground truth allows (absent ones stay empty), sampled as `options` say.
template <int D>
Metrics compute_metrics(const Snake<D>& snake, const GroundTruth<D>& truth, const MetricsOptions& options = {});

}  // namespace dsnake
