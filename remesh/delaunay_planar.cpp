// The "planar" method of §5.2: disc patches by recursive BFS halving, mean-value
// parameterisation with the boundary on a circle [Floater 2003], planar Delaunay triangulation
// of the parameter points (OpenCV Subdiv2D), connectivity adopted patch by patch in 3D.
#include "framework/mesh/edit_mesh.h"
#include "framework/geometry/triangle_measures.h"
#include "remesh/stage_steps.h"

#include <Eigen/Geometry>
#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <unordered_map>
#include <vector>

namespace dsnake::remesh_detail {

namespace {

using Edge = std::pair<int, int>;

// The directed boundary edges of a face set (edges whose twin lies outside the set).
std::vector<Edge> boundary_edges(const EditMesh& m, const std::vector<int>& faces, const std::set<int>& in) {
  std::vector<Edge> out;
  for (int f : faces) {
    const auto& t = m.tri(f);
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      const int twin = m.face_with_edge(b, a);
      if (!in.count(twin)) out.emplace_back(a, b);
    }
  }
  return out;
}

// The boundary as one simple loop in the faces' orientation, or empty if it is not one loop.
std::vector<int> boundary_loop(const std::vector<Edge>& edges) {
  std::unordered_map<int, int> next;
  for (const auto& [a, b] : edges)
    if (!next.emplace(a, b).second) return {};  // a pinched boundary vertex
  if (edges.empty()) return {};
  std::vector<int> loop;
  int v = edges.front().first;
  do {
    loop.push_back(v);
    v = next.at(v);
  } while (v != edges.front().first && loop.size() <= edges.size());
  if (loop.size() != edges.size()) return {};
  return loop;
}

// Connected components of a face set (through shared edges), each sorted.
std::vector<std::vector<int>> components(const EditMesh& m, const std::vector<int>& faces) {
  const std::set<int> in(faces.begin(), faces.end());
  std::set<int> seen;
  std::vector<std::vector<int>> out;
  for (int f0 : faces) {
    if (seen.count(f0)) continue;
    std::vector<int> comp{f0}, queue{f0};
    seen.insert(f0);
    for (size_t q = 0; q < queue.size(); ++q) {
      const auto& t = m.tri(queue[q]);
      for (int k = 0; k < 3; ++k) {
        const int g = m.face_with_edge(t[(k + 1) % 3], t[k]);
        if (g >= 0 && in.count(g) && seen.insert(g).second) {
          queue.push_back(g);
          comp.push_back(g);
        }
      }
    }
    std::sort(comp.begin(), comp.end());
    out.push_back(std::move(comp));
  }
  return out;
}

// A face set is a disc when V - E + F = 1 and its boundary is one simple loop.
bool is_disc(const EditMesh& m, const std::vector<int>& faces) {
  const std::set<int> in(faces.begin(), faces.end());
  const auto bnd = boundary_edges(m, faces, in);
  if (boundary_loop(bnd).empty()) return false;
  std::set<int> verts;
  for (int f : faces)
    for (int v : m.tri(f)) verts.insert(v);
  const long edges = (3 * static_cast<long>(faces.size()) + static_cast<long>(bnd.size())) / 2;
  return static_cast<long>(verts.size()) - edges + static_cast<long>(faces.size()) == 1;
}

// Whether a patch is flat enough to parameterise with little distortion: every face normal
// within 60 degrees of the patch's area-weighted mean normal.
bool is_flat(const EditMesh& m, const std::vector<int>& faces) {
  Point<3> mean = Point<3>::Zero();
  for (int f : faces) {
    const auto& t = m.tri(f);
    mean += (m.pos(t[1]) - m.pos(t[0])).cross(m.pos(t[2]) - m.pos(t[0]));
  }
  if (mean.squaredNorm() == 0) return false;
  mean.normalize();
  for (int f : faces) {
    const auto& t = m.tri(f);
    if (triangle_normal(m.pos(t[0]), m.pos(t[1]), m.pos(t[2])).dot(mean) < 0.5) return false;
  }
  return true;
}

// §5.2: split recursively in two (BFS from the first face until half the faces are marked)
// until every part is a disc. We also split patches that are not flat (is_flat): the
// mean-value map of a hemisphere-sized patch crowds the rim, and the planar Delaunay
// triangles there would be far from the surface.
void split_into_discs(const EditMesh& m, const std::vector<int>& faces, std::vector<std::vector<int>>& out, int depth) {
  for (auto& comp : components(m, faces)) {
    if (is_disc(m, comp) && is_flat(m, comp)) {
      out.push_back(std::move(comp));
      continue;
    }
    if (comp.size() < 4 || depth > 40) continue;  // left as it is
    const std::set<int> in(comp.begin(), comp.end());
    std::set<int> marked{comp.front()};
    std::vector<int> queue{comp.front()};
    for (size_t q = 0; q < queue.size() && marked.size() < comp.size() / 2; ++q) {
      const auto& t = m.tri(queue[q]);
      for (int k = 0; k < 3 && marked.size() < comp.size() / 2; ++k) {
        const int g = m.face_with_edge(t[(k + 1) % 3], t[k]);
        if (g >= 0 && in.count(g) && marked.insert(g).second) queue.push_back(g);
      }
    }
    std::vector<int> half_a(marked.begin(), marked.end()), half_b;
    for (int f : comp)
      if (!marked.count(f)) half_b.push_back(f);
    split_into_discs(m, half_a, out, depth + 1);
    split_into_discs(m, half_b, out, depth + 1);
  }
}

// Mean-value weights of interior vertex v over its ring (3D angles), normalised.
std::vector<double> mean_value_weights(const EditMesh& m, int v, const std::vector<int>& r) {
  const int k = static_cast<int>(r.size());
  std::vector<double> w(k), alpha(k);
  for (int i = 0; i < k; ++i) alpha[i] = angle_at(m.pos(v), m.pos(r[i]), m.pos(r[(i + 1) % k]));
  double sum = 0;
  for (int i = 0; i < k; ++i) {
    const double len = std::max((m.pos(r[i]) - m.pos(v)).norm(), 1e-300);
    w[i] = (std::tan(alpha[(i + k - 1) % k] / 2) + std::tan(alpha[i] / 2)) / len;
    sum += w[i];
  }
  for (double& x : w) x /= sum;
  return w;
}

// Mean-value parameterisation of a disc patch into `uv` (nv x 2, zero): the boundary loop on
// the unit circle by arc length, counter-clockwise (the faces' orientation), the interior
// vertices from one sparse LU solve; false when the solve fails.
bool parameterise_patch(const EditMesh& m, const std::vector<int>& verts, const std::unordered_map<int, int>& local,
                        const std::vector<int>& loop, const std::vector<char>& on_boundary, Eigen::MatrixX2d& uv) {
  const int nv = static_cast<int>(verts.size());
  const int nb = static_cast<int>(loop.size());
  std::vector<double> s(nb + 1, 0.0);
  for (int i = 0; i < nb; ++i) s[i + 1] = s[i] + (m.pos(loop[(i + 1) % nb]) - m.pos(loop[i])).norm();
  for (int i = 0; i < nb; ++i) {
    const double th = 2 * std::numbers::pi * s[i] / s[nb];
    uv.row(local.at(loop[i])) << std::cos(th), std::sin(th);
  }
  // Interior: u_i - sum_j w_ij u_j = sum over boundary j of w_ij u_j (one sparse LU solve).
  std::vector<int> interior_index(nv, -1);
  int ni = 0;
  for (int i = 0; i < nv; ++i)
    if (!on_boundary[i]) interior_index[i] = ni++;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::MatrixX2d rhs = Eigen::MatrixX2d::Zero(ni, 2);
  std::vector<int> ring;
  for (int i = 0; i < nv; ++i) {
    if (on_boundary[i]) continue;
    const int row = interior_index[i];
    m.ring(verts[i], ring);
    const auto w = mean_value_weights(m, verts[i], ring);
    trip.emplace_back(row, row, 1.0);
    for (size_t k = 0; k < ring.size(); ++k) {
      const int j = local.at(ring[k]);
      if (on_boundary[j]) rhs.row(row) += w[k] * uv.row(j);
      else trip.emplace_back(row, interior_index[j], -w[k]);
    }
  }
  Eigen::SparseMatrix<double> A(ni, ni);
  A.setFromTriplets(trip.begin(), trip.end());
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
  lu.compute(A);
  if (lu.info() != Eigen::Success) return false;
  const Eigen::MatrixX2d x = lu.solve(rhs);
  if (lu.info() != Eigen::Success || !x.allFinite()) return false;
  for (int i = 0; i < nv; ++i)
    if (!on_boundary[i]) uv.row(i) = x.row(interior_index[i]);
  return true;
}

// The triangle with its smallest vertex first (the same triangle whatever its starting corner).
std::array<int, 3> rotated_key(const std::array<int, 3>& t) {
  std::array<int, 3> key = t;
  std::rotate(key.begin(), std::min_element(key.begin(), key.end()), key.end());
  return key;
}

// Planar Delaunay triangles of the parameter points `uv` as mesh triangles (counter-clockwise in
// the plane = outward in 3D), each once, into `fresh`; false when two points merge in float or a
// triangle is flat. Subdiv2D works in float on an integer rectangle: the unit disc is scaled.
bool delaunay_triangles(const Eigen::MatrixX2d& uv, const std::vector<int>& verts, std::vector<Triangle>& fresh) {
  const int nv = static_cast<int>(verts.size());
  constexpr double kScale = 1000, kShift = 1010;
  cv::Subdiv2D sub(cv::Rect(0, 0, 2020, 2020));
  std::unordered_map<int, int> of_subdiv;  // Subdiv2D vertex id -> parameter index
  for (int i = 0; i < nv; ++i) {
    const int id = sub.insert(cv::Point2f(float(uv(i, 0) * kScale + kShift), float(uv(i, 1) * kScale + kShift)));
    if (!of_subdiv.emplace(id, i).second) return false;  // two points merged in float
  }
  std::vector<int> leading;
  sub.getLeadingEdgeList(leading);
  std::set<std::array<int, 3>> seen;
  for (int e : leading) {
    const int e1 = sub.getEdge(e, cv::Subdiv2D::NEXT_AROUND_LEFT);
    const int e2 = sub.getEdge(e1, cv::Subdiv2D::NEXT_AROUND_LEFT);
    if (sub.getEdge(e2, cv::Subdiv2D::NEXT_AROUND_LEFT) != e) continue;
    const int ids[3] = {sub.edgeOrg(e), sub.edgeOrg(e1), sub.edgeOrg(e2)};
    std::array<int, 3> t;
    bool real = true;
    for (int k = 0; k < 3 && real; ++k) {
      auto it = of_subdiv.find(ids[k]);
      real = it != of_subdiv.end();
      if (real) t[k] = it->second;
    }
    if (!real || t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    // Counter-clockwise in the parameter plane = outward in 3D.
    const Eigen::Vector2d a = uv.row(t[0]), b = uv.row(t[1]), c = uv.row(t[2]);
    const double orient = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (orient == 0) return false;
    if (orient < 0) std::swap(t[1], t[2]);
    if (!seen.insert(rotated_key(t)).second) continue;
    fresh.push_back({verts[t[0]], verts[t[1]], verts[t[2]]});
  }
  return true;
}

// Whether the new triangles number as many as the old and keep every boundary edge of the loop.
bool keeps_patch_boundary(const std::vector<Triangle>& fresh, size_t old_count, const std::vector<int>& loop) {
  if (fresh.size() != old_count) return false;
  const int nb = static_cast<int>(loop.size());
  std::set<Edge> fresh_edges;
  for (const auto& t : fresh)
    for (int k = 0; k < 3; ++k) fresh_edges.emplace(t[k], t[(k + 1) % 3]);
  for (int i = 0; i < nb; ++i)
    if (!fresh_edges.count({loop[i], loop[(i + 1) % nb]})) return false;
  return true;
}

// Whether the new triangles are the old ones (up to each triangle's starting corner).
bool same_triangles(const EditMesh& m, const std::vector<int>& faces, const std::vector<Triangle>& fresh) {
  std::set<std::array<int, 3>> old_keys;
  for (int f : faces) old_keys.insert(rotated_key(m.tri(f)));
  bool same = true;
  for (const auto& t : fresh) same = same && old_keys.count(rotated_key(t));
  return same;
}

// Geometry: every new triangle non-degenerate and within the dihedral limit (at least 60
// degrees: a patch spans more curvature than one edge) of the old surface's normal at each
// of its corners (area-weighted over the old patch faces).
bool fits_old_surface(const EditMesh& m, const std::vector<int>& faces, const std::vector<Triangle>& fresh,
                      double cos_max_dihedral) {
  std::unordered_map<int, Point<3>> vn;
  for (int f : faces) {
    const auto& t = m.tri(f);
    const Point<3> n = (m.pos(t[1]) - m.pos(t[0])).cross(m.pos(t[2]) - m.pos(t[0]));
    for (int v : t) {
      auto [it, fresh_v] = vn.emplace(v, n);
      if (!fresh_v) it->second += n;
    }
  }
  for (const auto& t : fresh) {
    const Point<3> n = triangle_normal(m.pos(t[0]), m.pos(t[1]), m.pos(t[2]));
    if (n.squaredNorm() == 0) return false;
    for (int v : t)
      if (n.dot(vn[v].normalized()) < std::min(cos_max_dihedral, 0.5)) return false;
  }
  return true;
}

// Swaps the patch in, triangle by triangle, checking each against the rest of the surface;
// on an intersection the old triangles are restored and false is returned.
bool swap_in_patch(EditMesh& m, const std::vector<int>& faces, const std::vector<Triangle>& fresh) {
  std::vector<Triangle> old;
  for (int f : faces) old.push_back(m.tri(f));
  for (int f : faces) m.remove_triangle(f);
  std::vector<int> added;
  for (const auto& t : fresh) {
    if (m.intersects(t, {})) {
      for (int f : added) m.remove_triangle(f);
      for (const auto& o : old) m.add_triangle(o);
      return false;
    }
    added.push_back(m.add_triangle(t));
  }
  return true;
}

// Re-triangulates one disc patch; returns false (patch untouched) when it cannot be done safely.
bool retriangulate_patch(EditMesh& m, const std::vector<int>& faces, double cos_max_dihedral) {
  const std::set<int> in(faces.begin(), faces.end());
  const auto loop = boundary_loop(boundary_edges(m, faces, in));
  std::vector<int> verts;
  for (int f : faces)
    for (int v : m.tri(f)) verts.push_back(v);
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  std::unordered_map<int, int> local;  // mesh vertex -> parameter index
  for (size_t i = 0; i < verts.size(); ++i) local[verts[i]] = static_cast<int>(i);
  const int nv = static_cast<int>(verts.size());
  std::vector<char> on_boundary(nv, 0);
  for (int v : loop) on_boundary[local[v]] = 1;
  if (nv == static_cast<int>(loop.size())) return false;  // no interior vertex

  Eigen::MatrixX2d uv = Eigen::MatrixX2d::Zero(nv, 2);
  if (!parameterise_patch(m, verts, local, loop, on_boundary, uv)) return false;
  std::vector<Triangle> fresh;
  if (!delaunay_triangles(uv, verts, fresh)) return false;
  // The same number of triangles and every boundary edge kept, or the patch stays.
  if (!keeps_patch_boundary(fresh, faces.size(), loop)) return false;
  if (same_triangles(m, faces, fresh)) return true;  // unchanged connectivity: nothing to do
  if (!fits_old_surface(m, faces, fresh, cos_max_dihedral)) return false;
  return swap_in_patch(m, faces, fresh);
}

}  // namespace

int planar_delaunay(EditMesh& m, double cos_max_dihedral) {
  std::vector<int> faces;
  for (int f = 0; f < m.num_triangle_slots(); ++f)
    if (m.tri_alive(f)) faces.push_back(f);
  std::vector<std::vector<int>> patches;
  split_into_discs(m, faces, patches, 0);
  int rejected = 0;
  for (const auto& patch : patches)
    if (!retriangulate_patch(m, patch, cos_max_dihedral)) ++rejected;
  return rejected;
}

}  // namespace dsnake::remesh_detail
