// Smoothing and decimation of extracted surfaces and contours (the OpenMesh decimater stays in
// mesh_processing.cpp; this header needs only the core types).
#pragma once

#include "framework/core/shape.h"

#include <vector>

namespace dsnake {

// Taubin's λ|μ smoothing (uniform umbrella weights; λ = 0.5, μ = -0.53 per step pair): removes
// the voxel staircase with little shrinking. `steps` λ|μ pairs; positions only, connectivity
// unchanged. Works on a closed mesh and on a closed polygon alike (neighbours from `c`).
template <int D>
PointList<D> taubin_smooth(const PointList<D>& p, const Connectivity& c, int steps);

// Settings of one decimation attempt: the binary modules that forbid a collapse.
struct DecimationLimits {
  double normal_deviation_deg = 30;  // ModNormalDeviation: no face normal turns more than this
  double aspect_ratio = 10;          // ModAspectRatio: no triangle more elongated than this
  double flip_deg = 60;              // ModNormalFlipping: no face turns more than this in one collapse
};

// The stricter limits used after an attempt whose result failed its checks (self-intersections,
// vertex count off), in order; the first is the default.
std::vector<DecimationLimits> decimation_attempts();

// The looser limits tried, in order, after an attempt that missed the vertex count (its limits
// forbade the collapses needed, as in a thin lobe of a large organ); the checks still apply.
std::vector<DecimationLimits> decimation_fallbacks();

// Half-edge collapses by quadric error (OpenMesh's Decimater, ModQuadric as priority) down to
// `target_vertices` or until the limits forbid every collapse. OpenMesh refuses collapses that
// would change the topology (the link condition), so a closed manifold mesh stays closed and
// manifold with the same Euler characteristic; the remaining vertices keep their positions.
struct DecimatedMesh {
  PointList<3> points;
  Connectivity connectivity;
};
DecimatedMesh decimate_mesh(const PointList<3>& p, const Connectivity& c, int target_vertices,
                            const DecimationLimits& limits);

// Quadric-error half-edge collapses with no limit but ModNormalFlipping (60°) down to about
// `target_vertices`: the simplification of the bunny phantom (experiments/phantoms/bunny.h), whose
// template vertices must stay on the true surface (a subset of p, exact positions, old order).
DecimatedMesh simplify_quadric(const PointList<3>& p, const Connectivity& c, int target_vertices);

// n points at equal arc-length steps along the closed polygon p, the first at p[0].
PointList<2> resample_closed_polygon(const PointList<2>& p, int n);

}  // namespace dsnake
