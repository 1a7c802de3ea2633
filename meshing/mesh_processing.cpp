// Taubin smoothing, OpenMesh decimation and polygon resampling; see mesh_processing.h.
#include "meshing/mesh_processing.h"

#include "framework/core/errors.h"
#include "framework/operators/mesh_operators.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModAspectRatioT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalDeviationT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {

using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// One umbrella step with factor f: p -= f L p (L the umbrella Laplacian, framework/operators).
template <int D>
void umbrella_step(PointList<D>& p, PointList<D>& scratch, const Connectivity& c, double f) {
  scratch = p;
  for (int v = 0; v < int(p.size()); ++v) {
    if (c.neighbors(v).empty()) continue;
    p[v] = scratch[v] + f * (one_ring_mean<D>(c, scratch, v) - scratch[v]);
  }
}

// The OpenMesh copy of a mesh, with the status and normal properties the decimater needs.
OMesh to_openmesh(const PointList<3>& p, const Connectivity& c) {
  OMesh m;
  std::vector<OMesh::VertexHandle> vh;
  vh.reserve(p.size());
  for (const auto& x : p) vh.push_back(m.add_vertex(OMesh::Point(x.x(), x.y(), x.z())));
  for (const Triangle& t : c.triangles()) m.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
  m.request_vertex_status();
  m.request_edge_status();
  m.request_halfedge_status();
  m.request_face_status();
  m.request_face_normals();
  m.update_face_normals();
  return m;
}

// The surviving vertices (old order) and faces of a decimated OpenMesh mesh. Positions come from
// p, the mesh it was built from: half-edge collapses move no vertex, and OpenMesh's default
// kernel stores single-precision points, so p keeps the double positions exact.
DecimatedMesh from_openmesh(const OMesh& m, const PointList<3>& p) {
  DecimatedMesh out;
  std::vector<int> new_id(m.n_vertices(), -1);
  for (auto v : m.vertices()) {
    if (m.status(v).deleted()) continue;
    new_id[v.idx()] = int(out.points.size());
    out.points.push_back(p[size_t(v.idx())]);
  }
  std::vector<Triangle> tris;
  for (auto f : m.faces()) {
    if (m.status(f).deleted()) continue;
    Triangle t;
    int k = 0;
    for (auto v : m.fv_range(f)) t[k++] = new_id[v.idx()];
    tris.push_back(t);
  }
  out.connectivity = Connectivity::mesh(int(out.points.size()), std::move(tris));
  return out;
}

}  // namespace

template <int D>
PointList<D> taubin_smooth(const PointList<D>& p, const Connectivity& c, int steps) {
  constexpr double kLambda = 0.5, kMu = -0.53;
  PointList<D> out = p, scratch;
  for (int s = 0; s < steps; ++s) {
    umbrella_step(out, scratch, c, kLambda);
    umbrella_step(out, scratch, c, kMu);
  }
  return out;
}

std::vector<DecimationLimits> decimation_attempts() {
  return {{150, 20, 60}, {120, 10, 30}, {90, 6, 15}};
}

std::vector<DecimationLimits> decimation_fallbacks() {
  return {{170, 60, 80}, {179, 200, 120}};
}

DecimatedMesh decimate_mesh(const PointList<3>& p, const Connectivity& c, int target_vertices,
                            const DecimationLimits& limits) {
  OMesh m = to_openmesh(p, c);
  {
    OpenMesh::Decimater::DecimaterT<OMesh> dec(m);
    OpenMesh::Decimater::ModQuadricT<OMesh>::Handle quadric;
    OpenMesh::Decimater::ModNormalDeviationT<OMesh>::Handle deviation;
    OpenMesh::Decimater::ModAspectRatioT<OMesh>::Handle aspect;
    OpenMesh::Decimater::ModNormalFlippingT<OMesh>::Handle flipping;
    dec.add(quadric);
    dec.add(deviation);
    dec.add(aspect);
    dec.add(flipping);
    dec.module(deviation).set_normal_deviation(float(limits.normal_deviation_deg));
    dec.module(aspect).set_aspect_ratio(float(limits.aspect_ratio));
    dec.module(flipping).set_max_normal_deviation(limits.flip_deg);
    DSNAKE_ASSERT(dec.initialize(), "the decimater accepts its modules");
    dec.decimate_to(size_t(std::max(target_vertices, 4)));
  }
  return from_openmesh(m, p);  // before any garbage collection: handles are still p's indices
}

DecimatedMesh simplify_quadric(const PointList<3>& p, const Connectivity& c, int target_vertices) {
  OMesh m = to_openmesh(p, c);
  {
    OpenMesh::Decimater::DecimaterT<OMesh> dec(m);
    OpenMesh::Decimater::ModQuadricT<OMesh>::Handle quadric;
    OpenMesh::Decimater::ModNormalFlippingT<OMesh>::Handle flipping;
    dec.add(quadric);
    dec.add(flipping);
    dec.module(flipping).set_max_normal_deviation(60.0);  // no collapse turns a face by more
    dec.initialize();
    dec.decimate_to(size_t(std::max(target_vertices, 4)));
  }
  return from_openmesh(m, p);
}

PointList<2> resample_closed_polygon(const PointList<2>& p, int n) {
  const int m = int(p.size());
  std::vector<double> s(m + 1, 0.0);  // arc length at each vertex, s[m] = perimeter
  for (int i = 0; i < m; ++i) s[i + 1] = s[i] + (p[(i + 1) % m] - p[i]).norm();
  PointList<2> out;
  int seg = 0;
  for (int k = 0; k < n; ++k) {
    const double t = s[m] * k / n;
    while (seg + 1 < m && s[seg + 1] <= t) ++seg;
    const double len = s[seg + 1] - s[seg];
    const double f = len > 0 ? (t - s[seg]) / len : 0.0;
    out.push_back(p[seg] + f * (p[(seg + 1) % m] - p[seg]));
  }
  return out;
}

template PointList<2> taubin_smooth<2>(const PointList<2>&, const Connectivity&, int);
template PointList<3> taubin_smooth<3>(const PointList<3>&, const Connectivity&, int);

}  // namespace dsnake
