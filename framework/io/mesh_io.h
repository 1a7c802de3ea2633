// Reading and writing templates, snakes and contours.
//  - 3D meshes through OpenMesh: OFF, OBJ, PLY, STL; plus legacy VTK POLYDATA (ASCII), which
//    also carries per-vertex scalars (template id, displacement) that ParaView shows.
//  - 2D contours: text (.txt, one "x y" line per vertex, '#' comments, implicitly closed),
//    JSON (.json, {"points": [[x, y], ...], "landmarks": {"name": id}}), and VTK POLYDATA
//    polylines (.vtk) with per-vertex scalars.
// Template vertex ids are the vertex indices / line numbers, from 0. A template mesh must be
// non-empty, closed and manifold (InputError naming the file and the element otherwise); an
// inward-oriented mesh is flipped to outward orientation (ids are unchanged) and a mesh of
// several separate surfaces is accepted, each surface turned outward on its own; either prints
// one warning line naming the file.
#pragma once

#include "framework/core/shape.h"

#include <string>
#include <vector>

namespace dsnake {

// A per-vertex array: `components` numbers per vertex (1: a scalar; 3: a vector, written as
// VTK VECTORS, which ParaView draws as arrows), vertex-major. Values must be finite: VTK's
// legacy reader refuses "nan", so a missing value is a documented sentinel beside a 0/1 array
// that says where it is missing (runner.cpp: "has_target").
struct VertexScalars {
  std::string name;            // e.g. "template_id", "displacement"
  std::vector<double> values;  // components per vertex, vertex-major
  int components = 1;
};

Template<3> read_mesh_template(const std::string& path);
Template<2> read_contour_template(const std::string& path);

// Reads a closed surface/contour (ground truth); same checks as the templates.
template <int D>
Template<D> read_shape(const std::string& path);

// Writes by extension (.off .obj .ply .stl .vtk for meshes; .txt .json .vtk for contours).
// Scalars are written where the format holds them (VTK; JSON contours), ignored elsewhere.
// Atomic: written under a temporary name, then renamed.
void write_mesh(const PointList<3>& points, const Connectivity& connectivity, const std::string& path,
                const std::vector<VertexScalars>& scalars = {});
void write_contour(const PointList<2>& points, const std::string& path,
                   const std::vector<VertexScalars>& scalars = {});
template <int D>
void write_shape(const PointList<D>& points, const Connectivity& connectivity, const std::string& path,
                 const std::vector<VertexScalars>& scalars = {});

}  // namespace dsnake
