// Template<D> (the fixed reference shape p, with landmarks) and Snake<D> (the evolving shape q).
// D = 2: a closed polygon in either orientation (vertex order = template id order).
// D = 3: a closed, manifold, outward-oriented triangle mesh (positive volume).
// Connectivity is kept apart from positions (as in geometry-central); every snake vertex that
// comes from the template keeps its template id (a "deformation vertex") through every remesh,
// vertices added later are "free" (id -1).
#pragma once

#include "framework/core/types.h"

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

namespace dsnake {

// Closed polygon (no triangles) or closed triangle mesh, with cached vertex adjacency.
class Connectivity {
 public:
  Connectivity() = default;
  static Connectivity polygon(int num_vertices);
  // Builds the adjacency; the one-ring of each vertex is ordered counter-clockwise when the
  // mesh is a closed oriented manifold (checked by closed_manifold()).
  static Connectivity mesh(int num_vertices, std::vector<Triangle> triangles);
  // A mesh that its builder keeps closed, manifold and oriented (the remeshers' EditMesh), with
  // its ordered one-rings given as mesh() would order them (v's ring at adjacency[offsets[v]]
  // up to adjacency[offsets[v + 1]]): taken as they are, without mesh()'s checks, so that a
  // remeshing pass writes back in linear time with no sorting.
  static Connectivity manifold_mesh(int num_vertices, std::vector<Triangle> triangles, std::vector<int> offsets,
                                    std::vector<int> adjacency);

  int num_vertices() const { return num_vertices_; }
  bool is_polygon() const { return triangles_.empty(); }
  const std::vector<Triangle>& triangles() const { return triangles_; }
  // Neighbours of v: (previous, next) on a polygon; the ordered one-ring on a mesh.
  std::span<const int> neighbors(int v) const {
    return {adjacency_.data() + offsets_[v], adjacency_.data() + offsets_[v + 1]};
  }
  std::vector<std::array<int, 2>> edges() const;  // each undirected edge once, (a < b)
  // Empty when the mesh is closed, manifold and consistently oriented; otherwise says why,
  // naming the first element at fault.
  std::string closed_manifold_problem() const;
  int euler_characteristic() const;  // V - E + F (polygon: 0)

 private:
  int num_vertices_ = 0;
  std::vector<Triangle> triangles_;
  std::vector<int> offsets_{0};
  std::vector<int> adjacency_;
  std::string problem_;
};

template <int D>
struct Template {
  PointList<D> positions;                    // p, physical units; the template id is the index
  Connectivity connectivity;
  std::map<std::string, int> landmarks;      // named feature vertices -> template id

  int num_vertices() const { return static_cast<int>(positions.size()); }
};

template <int D>
class Snake {
 public:
  Snake() = default;
  // A snake on the template's connectivity at positions q (one per template vertex).
  static Snake from_template(const Template<D>& tmpl, PointList<D> q);
  // template_ids[v] is the template id of vertex v, or -1 for a free vertex.
  Snake(PointList<D> q, Connectivity connectivity, std::vector<int> template_ids);

  int num_vertices() const { return static_cast<int>(positions_.size()); }
  PointList<D>& positions() { return positions_; }
  const PointList<D>& positions() const { return positions_; }
  const Connectivity& connectivity() const { return connectivity_; }
  const std::vector<int>& template_ids() const { return template_ids_; }
  int template_id(int v) const { return template_ids_[v]; }
  bool is_deformation_vertex(int v) const { return template_ids_[v] >= 0; }
  // Snake vertex carrying template id t, or -1 (inverse of template_ids()).
  int vertex_of_template_id(int t) const;
  int num_deformation_vertices() const;

  // Replaces vertices and connectivity (remeshers). Bumps topology_version() so that energies
  // and caches rebuild; a remesher must keep every deformation vertex's id and position.
  void set_topology(PointList<D> q, Connectivity connectivity, std::vector<int> template_ids);
  uint64_t topology_version() const { return topology_version_; }

  // Outward unit vertex normals: 2D from the two adjacent edges, 3D area-weighted face normals.
  PointList<D> vertex_normals() const;
  void vertex_normals(PointList<D>& out) const;  // the same, into `out` (no allocation once sized)
  // Signed area (2D: positive when counter-clockwise) or volume (3D: positive when outward).
  double signed_measure() const;

 private:
  void rebuild_inverse();

  PointList<D> positions_;
  Connectivity connectivity_;
  std::vector<int> template_ids_;
  std::vector<int> vertex_of_template_;
  uint64_t topology_version_ = 0;
};

// Signed area / volume of a closed polygon or mesh.
template <int D>
double signed_measure(const PointList<D>& p, const Connectivity& c);

// Outward unit vertex normals of a closed polygon or mesh at positions p (one per vertex of c):
// 2D from the two adjacent edges (outward by the sign of the area), 3D area-weighted face normals.
template <int D>
void vertex_normals(const PointList<D>& p, const Connectivity& c, PointList<D>& out);
template <int D>
PointList<D> vertex_normals(const PointList<D>& p, const Connectivity& c);

// Applies scale and rotation (degrees; x, then y, then z) about the centroid of p, then the
// translation: the placement of "template.transform" (docs/experiment-file.md).
template <int D>
PointList<D> place(const PointList<D>& p, double scale, const std::vector<double>& rotation_deg,
                   const Point<D>& translation);

}  // namespace dsnake
