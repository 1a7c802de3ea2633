// The boundary of a binary mask (label_mask.h) as a closed surface (3D) or contour (2D).
//
// Why our own marching cubes, and why this construction: OpenVDB (volume to mesh) is a heavy
// dependency for a binary mask; marching tetrahedra has no ambiguous cases but its fixed split
// of the cube connects voxels along one family of diagonals and not the mirrored one, so the
// genus depends on the orientation of the object in the grid. Marching cubes with one rule for
// every ambiguous face gives a topology defined by a symmetric connectivity:
//  - on each cube face, the crossings (edge midpoints between an inside and an outside voxel
//    centre) are joined by segments that cut off the inside corners; on an ambiguous face (two
//    diagonal inside corners) each inside corner is cut off alone. So diagonal voxels are never
//    joined: the object is 6-connected (2D: 4-connected), and two background corners on an
//    ambiguous face are joined. The one case the faces leave open in 3D, a cube whose only
//    outside corners are two opposite ones, gets a tunnel (a band of six triangles) joining them:
//    the background is 26-connected (2D: 8-connected), and the surface's genus is the genus of
//    the object's 6-connected cubical complex (voxel centres, 6-neighbour edges, full squares
//    and cubes: χ(surface) = 2 (V - E + F - C), tested on random masks);
//  - in each cube the face segments form closed loops (each crossing lies on two faces of the
//    cube); a loop of three is one triangle, a longer loop a fan of triangles around a new
//    vertex at the loop's centroid. No case table: the loops are found per cube, so both cubes
//    sharing a face use the same segments, and the surface is closed and edge-manifold; each
//    crossing belongs to one loop per cube, so it is vertex-manifold too.
// No two triangles intersect (random masks of every density are tested for it, and for the
// Euler characteristic). Vertices are in world coordinates (the mask grid's origin + index * spacing, anisotropic
// spacing allowed); the surface is oriented outward (positive signed volume). With vertices at
// edge midpoints, every inside voxel centre is inside the surface and every outside one outside
// (Dice 1 on the voxel grid before smoothing).
#pragma once

#include "framework/core/shape.h"
#include "meshing/label_mask.h"

#include <vector>

namespace dsnake {

struct ExtractedSurface {
  PointList<3> points;
  std::vector<Triangle> triangles;
};

// The closed, outward surface of the mask's inside voxels (one or more components).
ExtractedSurface marching_cubes(const LabelMask<3>& mask);

// The closed contours of the mask's inside pixels (same rules in 2D: marching squares), each
// counter-clockwise around the inside (a hole's contour therefore clockwise in world space).
std::vector<PointList<2>> marching_squares(const LabelMask<2>& mask);

}  // namespace dsnake
