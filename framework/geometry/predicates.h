// Exact intersection predicates of segments (2D) and triangles (3D), closed sets, by signs of
// orientation determinants: the test behind the self-intersection metric
// (framework/metrics/metrics.h) and the collision guard's exact pair tests
// (framework/guard/collision_guard.h, framework/geometry/triangle_pairs.h). A facet is a segment
// (D = 2) or a triangle (D = 3), given by D vertex indices; a FacetSurface is a boundary with its
// vertices in physical units.
#pragma once

#include "framework/core/types.h"

#include <array>
#include <vector>

namespace dsnake {

template <int D>
using Facet = std::array<int, D>;

// A boundary: vertices (physical units) and the facets over them.
template <int D>
struct FacetSurface {
  PointList<D> vertices;
  std::vector<Facet<D>> facets;
};

// true if the closed segments [a, b] and [c, d] share a point (proper crossing or touching).
bool segments_intersect(const Point<2>& a, const Point<2>& b, const Point<2>& c, const Point<2>& d);

// true if the closed triangles p and q share a point (crossing, touching or coplanar overlap).
bool triangles_intersect(const std::array<Point<3>, 3>& p, const std::array<Point<3>, 3>& q);

}  // namespace dsnake
