// Where every snake vertex sits on the template: its rest position p in the template's frame.
// A deformation vertex's is its template position. A free vertex (inserted by a remesher, §6)
// has none of its own; it lies where the surface near it lies, so its rest position is where
// the local similarity that takes the nearest deformation vertices' current positions q_i onto
// their template positions p_i takes its own q (the as-similar-as-possible model of §4 read
// backwards: locally the template is a similar copy of the snake). The fit is Umeyama's weighted
// least-squares similarity (mls_weights.h) over the `count` deformation vertices nearest along the
// mesh (breadth-first over edges, ties in the order the rings list them), weighted by
// 1 / (|q_i - q|^2 + eps^2). Exact wherever the snake is a similar copy of the template near v;
// its rotation also turns v's normal into the template's frame. The point it gives lies on the
// template's facets, a chord of the curved object; it is then moved along the turned normal onto
// the quadric height field fitted to the same template vertices (a free vertex inserted at an
// edge's midpoint lands on the curved surface, not on the chord).
#pragma once

#include "framework/core/shape.h"

#include <Eigen/Core>
#include <vector>

namespace dsnake {

template <int D>
struct RestPositions {
  PointList<D> positions;                            // one per snake vertex, template frame
  std::vector<Eigen::Matrix<double, D, D>> rotation;  // snake frame -> template frame, per vertex
};

// The rest positions of every vertex of `snake`, whose deformation vertices carry ids of `tmpl`.
// Deformation vertices: p = tmpl.positions[id] and rotation = the rotation of the same fit made
// over their neighbours (so a template vertex's rest position is exact). `count`: the deformation
// vertices in each fit (at least D). Deterministic and serial per vertex (each vertex alone).
template <int D>
RestPositions<D> rest_positions(const Template<D>& tmpl, const Snake<D>& snake, int count = 4 * D);

}  // namespace dsnake
