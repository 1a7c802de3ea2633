// Registration metrics (see metrics.h). Surfaces are sampled densely, each sample weighted by
// its share of length (2D) or area (3D), and the exact distance from every sample to the other
// surface is found with a uniform grid over that surface's facets
// (framework/geometry/facet_grid.h).
#include "framework/metrics/metrics.h"

#include "framework/core/errors.h"
#include "framework/geometry/predicates.h"
#include "framework/geometry/facet_grid.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <utility>

namespace dsnake {

namespace {


constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Points on a surface, each with the length (2D) or area (3D) it stands for, in batches of
// nearby points (one facet's samples, or a single vertex) that are queried together.
template <int D>
struct Samples {
  PointList<D> points;
  std::vector<double> weights;
  std::vector<int64_t> batches;  // first sample of each batch

  void begin_batch() { batches.push_back(static_cast<int64_t>(points.size())); }

  void add(const Point<D>& p, double w) {
    points.push_back(p);
    weights.push_back(w);
  }
};

// The facets of a closed polygon (edges i -> i+1) or of a closed mesh (its triangles).
template <int D>
FacetSurface<D> facets_of(SurfaceRef<D> s) {
  const int n = s.connectivity.num_vertices();
  DSNAKE_ASSERT(int(s.points.size()) == n, "one position per vertex");
  FacetSurface<D> out;
  out.vertices = s.points;
  if constexpr (D == 2) {
    DSNAKE_ASSERT(s.connectivity.is_polygon(), "a 2D surface is a closed polygon");
    for (int i = 0; i < n && n >= 2; ++i) out.facets.push_back({i, (i + 1) % n});
  } else {
    DSNAKE_ASSERT(!s.connectivity.is_polygon(), "a 3D surface is a triangle mesh");
    for (const Triangle& t : s.connectivity.triangles()) out.facets.push_back(t);
  }
  return out;
}

// Samples at the midpoints of ceil(length / h) equal pieces of [a, b], weighted by length, in
// batches of consecutive pieces about `block` long (batched queries, FacetGrid::batch_distances).
template <int D>
void sample_segment(const Point<D>& a, const Point<D>& b, double h, double block, Samples<D>& out) {
  const double len = (b - a).norm();
  const int n = std::max(1, static_cast<int>(std::ceil(len / h)));
  const int per_batch = len > 0 ? static_cast<int>(std::clamp(block / (len / n), 1.0, double(n))) : n;
  for (int k = 0; k < n; ++k) {
    if (k % per_batch == 0) out.begin_batch();
    out.add(a + ((k + 0.5) / n) * (b - a), len / n);
  }
}

// Splits the triangle into n^2 congruent pieces (n = ceil(longest edge / h)) and samples each
// piece at its centroid with a weight of area / n^2. The pieces come in batches of B x B
// (in the triangle's (i, j) lattice), each about `block` wide, so that a large triangle's
// samples are queried as many small, tight batches rather than one loose one.
void sample_triangle(const Point<3>& a, const Point<3>& b, const Point<3>& c, double h, double block, Samples<3>& out) {
  const Point<3> e0 = b - a, e1 = c - a;
  const double longest = std::max({e0.norm(), e1.norm(), (c - b).norm()});
  const int n = std::max(1, static_cast<int>(std::ceil(longest / h)));
  const int B = longest > 0 ? static_cast<int>(std::clamp(block / (longest / n), 1.0, double(n))) : n;
  const double w = 0.5 * e0.cross(e1).norm() / (double(n) * n);
  for (int i0 = 0; i0 < n; i0 += B)
    for (int j0 = 0; i0 + j0 < n; j0 += B) {
      out.begin_batch();
      for (int i = i0; i < std::min(n, i0 + B); ++i)
        for (int j = j0; j < j0 + B && i + j < n; ++j) {
          out.add(a + ((i + 1.0 / 3) / n) * e0 + ((j + 1.0 / 3) / n) * e1, w);  // upright piece
          if (i + j + 1 < n) out.add(a + ((i + 2.0 / 3) / n) * e0 + ((j + 2.0 / 3) / n) * e1, w);
        }
    }
}

template <int D>
int64_t sample_count(const FacetSurface<D>& s, const std::vector<double>& longest, double h);
template <int D>
std::vector<double> longest_edges(const FacetSurface<D>& s);

// Vertices (weight 0: they count for the Hausdorff distance only) and facet samples, batched
// in blocks about `block` wide.
template <int D>
Samples<D> sample_surface(const FacetSurface<D>& s, double h, double block) {
  Samples<D> out;
  // The count is known (as surface_spacing counts it): sized once, not regrown (up to a million
  // samples, 32 bytes each, whose regrowth copies and pages in several times as much).
  const int64_t count = sample_count(s, longest_edges(s), h);
  out.points.reserve(count);
  out.weights.reserve(count);
  for (const auto& v : s.vertices) {
    out.begin_batch();
    out.add(v, 0.0);
  }
  for (const auto& f : s.facets) {
    if constexpr (D == 2) {
      sample_segment<2>(s.vertices[f[0]], s.vertices[f[1]], h, block, out);
    } else {
      sample_triangle(s.vertices[f[0]], s.vertices[f[1]], s.vertices[f[2]], h, block, out);
    }
  }
  return out;
}

// A facet's longest edge: sample_segment / sample_triangle cut it into ceil(longest / h) pieces
// per edge, i.e. n (2D) or n^2 (3D) samples.
template <int D>
std::vector<double> longest_edges(const FacetSurface<D>& s) {
  std::vector<double> out;
  out.reserve(s.facets.size());
  for (const auto& f : s.facets) {
    double longest = 0;
    for (int k = 0; k < D; ++k) longest = std::max(longest, (s.vertices[f[(k + 1) % D]] - s.vertices[f[k]]).norm());
    out.push_back(longest);
  }
  return out;
}

// Pieces per edge of a facet whose longest edge is `longest`, at spacing h (as the samplers).
inline int64_t pieces(double longest, double h) {
  return std::max<int64_t>(1, static_cast<int64_t>(std::ceil(longest / h)));
}

// The number of samples sample_surface(s, h, .) makes (longest: longest_edges(s)).
template <int D>
int64_t sample_count(const FacetSurface<D>& s, const std::vector<double>& longest, double h) {
  int64_t n = int64_t(s.vertices.size());
  for (double l : longest) {
    const int64_t k = pieces(l, h);
    n += D == 2 ? k : k * k;
  }
  return n;
}

// The spacing at which sample_surface(s, .) gives at most max_samples samples (bounded_spacing).
template <int D>
double surface_spacing(const FacetSurface<D>& s, double finest, int64_t max_samples) {
  const std::vector<double> longest = longest_edges(s);
  const double coarsest = longest.empty() ? finest : std::max(finest, *std::max_element(longest.begin(), longest.end()));
  return bounded_spacing(finest, coarsest, max_samples, [&](double h) { return sample_count(s, longest, h); });
}

// A mask's boundary faces as facets, and per face its lowest corner's vertex and its axis (the
// face is normal to that axis), from which the samples are made at a chosen spacing.
template <int D>
struct MaskBoundary {
  FacetSurface<D> surface;
  // Per face: its lowest corner's vertex, the next corner along the face, the normal axis, and
  // the number of vertices once the face was made (the corners it added come just before).
  std::vector<std::array<int, 4>> faces;
  std::array<int64_t, D> faces_per_axis{};
};

// The faces between an inside voxel (non-zero) and an outside one (zero or off the grid), in
// physical units: segments in 2D, squares split into two triangles in 3D. Face corners sit
// half a voxel from the centres; each corner becomes one vertex.
template <int D>
MaskBoundary<D> mask_boundary(const BinaryMask<D>& mask) {
  const Grid<D>& g = mask.grid();
  MaskBoundary<D> out;
  std::unordered_map<int64_t, int> corner_vertex;
  auto vertex = [&](const GridIndex<D>& corner) {  // corner lattice index, 0..size per axis
    int64_t key = corner[D - 1];
    for (int a = D - 2; a >= 0; --a) key = key * (g.size[a] + 1) + corner[a];
    auto [it, added] = corner_vertex.try_emplace(key, int(out.surface.vertices.size()));
    if (added)
      out.surface.vertices.push_back(g.origin + (corner.template cast<double>() - Point<D>::Constant(0.5)).cwiseProduct(g.spacing));
    return it->second;
  };
  auto inside = [&](const GridIndex<D>& idx) {
    for (int a = 0; a < D; ++a)
      if (idx[a] < 0 || idx[a] >= g.size[a]) return false;
    return mask.at(idx);
  };
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    if (!mask[l]) continue;
    const GridIndex<D> idx = g.index(l);
    for (int a = 0; a < D; ++a)
      for (int side = 0; side < 2; ++side) {
        GridIndex<D> nb = idx;
        nb[a] += side ? 1 : -1;
        if (inside(nb)) continue;
        GridIndex<D> c0 = idx;  // the face's lowest corner
        c0[a] += side;
        const int u = (a + 1) % D;
        GridIndex<D> cu = c0;
        ++cu[u];
        const int i00 = vertex(c0), i10 = vertex(cu);
        ++out.faces_per_axis[a];
        if constexpr (D == 2) {
          out.surface.facets.push_back({i00, i10});
        } else {
          const int v = (a + 2) % 3;
          GridIndex<3> cv = c0, cuv = cu;
          ++cv[v];
          ++cuv[v];
          const int i11 = vertex(cuv), i01 = vertex(cv);
          out.surface.facets.push_back({i00, i10, i11});
          out.surface.facets.push_back({i00, i11, i01});
        }
        out.faces.push_back({i00, i10, a, int(out.surface.vertices.size())});
      }
  }
  return out;
}

// Samples per face normal to `axis` at spacing h: a segment cut into ceil(side / h) pieces (2D),
// a square into a regular grid of ceil(side / h) cells per side (3D).
template <int D>
int64_t face_samples(const Point<D>& spacing, int axis, double h) {
  if constexpr (D == 2) return pieces(spacing[(axis + 1) % 2], h);
  return pieces(spacing[(axis + 1) % 3], h) * pieces(spacing[(axis + 2) % 3], h);
}

// The corners (weight 0) and every face's samples at spacing h: one batch per face, holding
// the corners that face added and its samples (all within a voxel of each other).
template <int D>
Samples<D> sample_mask_boundary(const MaskBoundary<D>& b, const Point<D>& spacing, double h) {
  Samples<D> out;
  int corners_done = 0;
  for (const auto& [corner, next, a, corners_end] : b.faces) {
    out.begin_batch();
    for (; corners_done < corners_end; ++corners_done) out.add(b.surface.vertices[corners_done], 0.0);
    const Point<D>& x0 = b.surface.vertices[corner];
    const int u = (a + 1) % D;
    if constexpr (D == 2) {
      const double len = spacing[u];
      const int64_t n = pieces(len, h);
      for (int64_t k = 0; k < n; ++k) out.add(x0 + ((k + 0.5) / n) * (b.surface.vertices[next] - x0), len / n);
    } else {
      const int v = (a + 2) % 3;
      const double su = spacing[u], sv = spacing[v];
      const int64_t nu = pieces(su, h), nv = pieces(sv, h);
      for (int64_t j = 0; j < nv; ++j)
        for (int64_t i = 0; i < nu; ++i) {
          Point<3> x = x0;
          x[u] += (i + 0.5) / nu * su;
          x[v] += (j + 0.5) / nv * sv;
          out.add(x, su * sv / double(nu * nv));
        }
    }
  }
  return out;
}

// The spacing at which sample_mask_boundary gives at most max_samples samples.
template <int D>
double mask_spacing(const MaskBoundary<D>& b, const Point<D>& spacing, double finest, int64_t max_samples) {
  return bounded_spacing(finest, std::max(finest, spacing.maxCoeff()), max_samples, [&](double h) {
    int64_t n = int64_t(b.surface.vertices.size());
    for (int a = 0; a < D; ++a) n += b.faces_per_axis[a] * face_samples<D>(spacing, a, h);
    return n;
  });
}

// Exact distance from every sample to the surface behind `grid`, in parallel over batches;
// each distance is the exact minimum over facets, so it does not depend on the thread count.
template <int D>
std::vector<double> nearest_distances(const FacetGrid<D>& grid, const Samples<D>& samples) {
  std::vector<double> d(samples.points.size());
  const int64_t nb = static_cast<int64_t>(samples.batches.size());
#pragma omp parallel
  {
    auto scratch = grid.make_scratch();
#pragma omp for schedule(dynamic, 64)
    for (int64_t b = 0; b < nb; ++b) {
      const int64_t begin = samples.batches[b];
      const int64_t end = b + 1 < nb ? samples.batches[b + 1] : int64_t(samples.points.size());
      grid.batch_distances(samples.points.data() + begin, end - begin, d.data() + begin, scratch);
    }
  }
  return d;
}

// One direction: each sample's distance to the other surface, with the sample's weight. The
// sample points are dropped once measured, so that the two surfaces' points (up to a million
// each) are not held while the pooled distances are sorted.
struct DirectedDistances {
  std::vector<double> weights, distances;
};
template <int D>
DirectedDistances directed_distances(const FacetGrid<D>& target, Samples<D>&& samples) {
  DirectedDistances r;
  r.distances = nearest_distances(target, samples);
  r.weights = std::move(samples.weights);
  samples = Samples<D>();
  return r;
}

// Symmetric summary of the two directed distance sets. HD95 is the weighted 95th percentile of
// the pooled distances, each direction's weights scaled to total 1/2 (as the mean does), so a
// finely staircased mask boundary does not outweigh the other surface.
SurfaceDistances summarize(const DirectedDistances& a, const DirectedDistances& b) {
  if (a.distances.empty() || b.distances.empty()) return {kInfinity, kInfinity, kInfinity};
  const std::vector<double>& da = a.distances;
  const std::vector<double>& db = b.distances;
  std::vector<std::pair<double, double>> pooled;  // (distance, weight)
  pooled.reserve(da.size() + db.size());
  SurfaceDistances r;
  r.mean = 0;
  for (int side = 0; side < 2; ++side) {
    const std::vector<double>& weights = side ? b.weights : a.weights;
    const std::vector<double>& d = side ? db : da;
    double total = 0;
    for (double w : weights) total += w;
    const bool unweighted = !(total > 0);  // degenerate surface: count samples instead
    if (unweighted) total = double(d.size());
    double sum = 0;
    for (size_t i = 0; i < d.size(); ++i) {
      const double w = (unweighted ? 1.0 : weights[i]) / (2 * total);
      sum += w * d[i];
      pooled.emplace_back(d[i], w);
      r.hausdorff = std::max(r.hausdorff, d[i]);
    }
    r.mean += sum;
  }
  // The smallest distance whose cumulative weight reaches 95%. Partition at the unweighted 90th
  // percentile first, then sort only the part that holds the answer.
  double total = 0;
  for (const auto& p : pooled) total += p.second;
  const double target = 0.95 * total;
  auto split = pooled.begin() + static_cast<std::ptrdiff_t>(0.9 * double(pooled.size()));
  std::nth_element(pooled.begin(), split, pooled.end());
  double cumulative = 0;
  for (auto it = pooled.begin(); it != split; ++it) cumulative += it->second;
  auto first = split;
  if (cumulative >= target) {
    first = pooled.begin();
    cumulative = 0;
    std::sort(pooled.begin(), split);
  } else {
    std::sort(split, pooled.end());
  }
  r.hausdorff95 = r.hausdorff;
  for (auto it = first; it != pooled.end(); ++it) {
    cumulative += it->second;
    if (cumulative >= target) {
      r.hausdorff95 = it->first;
      break;
    }
  }
  return r;
}

// The width of the sample batches queried against `target`: two of its cells (batches wider
// than four fall back to one query per point).
template <int D>
double batch_block(const FacetGrid<D>& target) {
  return 2 * target.cell_size();
}

// Sorted x positions where the row through the voxel centres at `y` (2D) crosses the polygon.
// Half-open rule: an edge counts when exactly one end lies strictly above y.
std::vector<double> row_crossings(const PointList<2>& p, double y) {
  std::vector<double> xs;
  const size_t n = p.size();
  for (size_t i = 0; i < n; ++i) {
    const Point<2>& a = p[i];
    const Point<2>& b = p[(i + 1) % n];
    if ((a.y() > y) != (b.y() > y)) xs.push_back(a.x() + (y - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
  }
  std::sort(xs.begin(), xs.end());
  return xs;
}

// Even-odd fill of one row of voxels from its sorted crossings: inside when an odd number of
// crossings lies before the voxel centre.
// The row holds voxels first .. first + nx - 1 of the grid's row (x0: the grid's origin).
void fill_row(const std::vector<double>& xs, double x0, double dx, int first, int nx, float* row) {
  size_t k = 0;
  for (int i = 0; i < nx; ++i) {
    const double x = x0 + (first + i) * dx;
    while (k < xs.size() && xs[k] < x) ++k;
    row[i] = (k % 2) ? 1.0f : 0.0f;
  }
}

// Side of the projected edge u -> v that q = (y, z) lies on: the edge function is evaluated
// from the lower-indexed vertex, so the two triangles sharing an edge see exactly opposite
// values, and a zero is broken by the symbolic shift q + (eps, eps^2) (Edelsbrunner and Mücke,
// "Simulation of Simplicity", 1990), so a ray through an edge or vertex is counted once.
// Returns the sign (0 only for an edge that projects to a point) and the unshifted value.
std::pair<int, double> edge_side(const PointList<3>& p, int iu, int iv, double y, double z) {
  const bool flip = iu > iv;
  if (flip) std::swap(iu, iv);
  const Point<3>& u = p[iu];
  const Point<3>& v = p[iv];
  const double w = (v.y() - u.y()) * (z - u.z()) - (v.z() - u.z()) * (y - u.y());
  double tie = w;
  if (tie == 0) tie = -(v.z() - u.z());
  if (tie == 0) tie = v.y() - u.y();
  const int sign = (tie > 0) - (tie < 0);
  return flip ? std::pair{-sign, -w} : std::pair{sign, w};
}

// x where the ray along +x through (y, z) crosses triangle t, if it does.
bool ray_crossing(const PointList<3>& p, const Triangle& t, double y, double z, double& x) {
  const auto [s0, w0] = edge_side(p, t[1], t[2], y, z);  // w0 ~ barycentric of t[0]
  const auto [s1, w1] = edge_side(p, t[2], t[0], y, z);
  const auto [s2, w2] = edge_side(p, t[0], t[1], y, z);
  if (s0 == 0 || s0 != s1 || s1 != s2) return false;
  const double sum = w0 + w1 + w2;
  x = sum != 0 ? (w0 * p[t[0]].x() + w1 * p[t[1]].x() + w2 * p[t[2]].x()) / sum
               : (p[t[0]].x() + p[t[1]].x() + p[t[2]].x()) / 3;
  return true;
}

// A box of whole voxels of a grid: the first voxel's index and the voxels per axis.
template <int D>
struct VoxelRange {
  GridIndex<D> lo = GridIndex<D>::Zero(), size = GridIndex<D>::Zero();
  int64_t num_voxels() const { return size.template cast<int64_t>().prod(); }
};

// The box's voxels as a grid of their own (the same spacing and direction, origin at lo).
template <int D>
Grid<D> sub_grid(const Grid<D>& g, const VoxelRange<D>& box) {
  Grid<D> sub = g;
  sub.size = box.size;
  sub.origin = g.to_physical(box.lo);
  return sub;
}

// Rasterisation, 2D: an even-odd scanline per row of voxel centres, over the box's voxels;
// centres are computed from the whole grid's indices, so a voxel's value does not depend on the box.
Image<2> rasterize(SurfaceRef<2> s, const Grid<2>& grid, const VoxelRange<2>& box) {
  Image<2> out(sub_grid(grid, box));
  const int nx = box.size[0], ny = box.size[1];
#pragma omp parallel for schedule(dynamic, 4)
  for (int j = 0; j < ny; ++j) {
    const auto xs = row_crossings(s.points, grid.origin.y() + (box.lo[1] + j) * grid.spacing.y());
    fill_row(xs, grid.origin.x(), grid.spacing.x(), box.lo[0], nx, &out[int64_t(j) * nx]);
  }
  return out;
}

// Rasterisation, 3D: a ray along x per (y, z) row of voxel centres of the box, counting
// crossings with the triangles (bucketed by the z slices they span); even-odd fill.
Image<3> rasterize(SurfaceRef<3> s, const Grid<3>& grid, const VoxelRange<3>& box) {
  Image<3> out(sub_grid(grid, box));
  const int nx = box.size[0], ny = box.size[1], nz = box.size[2];
  const auto& tris = s.connectivity.triangles();
  const auto& p = s.points;
  std::vector<std::array<int, 2>> slices(tris.size());  // z slice range of each triangle, in the box
  std::vector<int64_t> offsets(nz + 1, 0);
  for (size_t t = 0; t < tris.size(); ++t) {
    double lo = kInfinity, hi = -kInfinity;
    for (int v : tris[t]) lo = std::min(lo, p[v].z()), hi = std::max(hi, p[v].z());
    const double k0 = std::max(double(box.lo[2]), std::ceil((lo - grid.origin.z()) / grid.spacing.z()));
    const double k1 = std::min(double(box.lo[2] + nz - 1), std::floor((hi - grid.origin.z()) / grid.spacing.z()));
    slices[t] = k0 <= k1 ? std::array<int, 2>{int(k0) - box.lo[2], int(k1) - box.lo[2]} : std::array<int, 2>{0, -1};
    for (int k = slices[t][0]; k <= slices[t][1]; ++k) ++offsets[k + 1];
  }
  for (int k = 0; k < nz; ++k) offsets[k + 1] += offsets[k];
  std::vector<int> in_slice(offsets[nz]);
  std::vector<int64_t> fill(offsets.begin(), offsets.end() - 1);
  for (size_t t = 0; t < tris.size(); ++t)
    for (int k = slices[t][0]; k <= slices[t][1]; ++k) in_slice[fill[k]++] = int(t);

#pragma omp parallel for schedule(dynamic, 8)
  for (int64_t row = 0; row < int64_t(ny) * nz; ++row) {
    const int j = int(row % ny), k = int(row / ny);
    const double y = grid.origin.y() + (box.lo[1] + j) * grid.spacing.y();
    const double z = grid.origin.z() + (box.lo[2] + k) * grid.spacing.z();
    std::vector<double> xs;
    for (int64_t q = offsets[k]; q < offsets[k + 1]; ++q) {
      const Triangle& t = tris[in_slice[q]];
      if (std::min({p[t[0]].y(), p[t[1]].y(), p[t[2]].y()}) > y ||
          std::max({p[t[0]].y(), p[t[1]].y(), p[t[2]].y()}) < y)
        continue;
      double x;
      if (ray_crossing(p, t, y, z, x)) xs.push_back(x);
    }
    std::sort(xs.begin(), xs.end());
    fill_row(xs, grid.origin.x(), grid.spacing.x(), box.lo[0], nx, &out[row * nx]);
  }
  return out;
}

// The voxels whose centres lie in the points' bounding box, widened by one voxel and clamped
// to the grid (empty when the box misses the grid): every voxel whose centre is inside the
// closed surface of these points.
template <int D>
VoxelRange<D> voxels_around(const PointList<D>& points, const Grid<D>& g) {
  VoxelRange<D> r;
  if (points.empty()) return r;
  Point<D> lo = points[0], hi = points[0];
  for (const auto& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  for (int a = 0; a < D; ++a) {
    const double i0 = std::floor((lo[a] - g.origin[a]) / g.spacing[a]) - 1;
    const double i1 = std::ceil((hi[a] - g.origin[a]) / g.spacing[a]) + 1;
    const double first = std::max(0.0, i0), last = std::min(double(g.size[a] - 1), i1);
    if (!(first <= last)) return VoxelRange<D>{};
    r.lo[a] = int(first);
    r.size[a] = int(last - first) + 1;
  }
  return r;
}

// The box of the mask's non-zero voxels (empty when there are none).
template <int D>
VoxelRange<D> nonzero_voxels(const BinaryMask<D>& mask) {
  const Grid<D>& g = mask.grid();
  GridIndex<D> lo = g.size, hi = GridIndex<D>::Constant(-1);
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    if (!mask[l]) continue;
    const GridIndex<D> idx = g.index(l);
    lo = lo.cwiseMin(idx), hi = hi.cwiseMax(idx);
  }
  VoxelRange<D> r;
  if (hi[0] < 0) return r;
  r.lo = lo;
  r.size = hi - lo + GridIndex<D>::Ones();
  return r;
}

// The smallest box holding two boxes (an empty box holds nothing).
template <int D>
VoxelRange<D> union_of(const VoxelRange<D>& a, const VoxelRange<D>& b) {
  if (a.num_voxels() == 0) return b;
  if (b.num_voxels() == 0) return a;
  VoxelRange<D> r;
  r.lo = a.lo.cwiseMin(b.lo);
  r.size = (a.lo + a.size).cwiseMax(b.lo + b.size) - r.lo;
  return r;
}

// Whether facets f and g of a surface share a vertex.
template <int D>
bool share_vertex(const Facet<D>& f, const Facet<D>& g) {
  for (int a : f)
    for (int b : g)
      if (a == b) return true;
  return false;
}

}  // namespace

template <int D>
std::vector<double> distances_to_surface(SurfaceRef<D> s, const PointList<D>& points) {
  Samples<D> batch;  // one point per batch
  for (const auto& p : points) {
    batch.begin_batch();
    batch.add(p, 0.0);
  }
  return nearest_distances(FacetGrid<D>(facets_of(s)), batch);
}

double bounded_spacing(double finest, double coarsest, int64_t max_samples,
                       const std::function<int64_t(double)>& count) {
  DSNAKE_ASSERT(finest > 0 && coarsest >= finest, "0 < finest <= coarsest");
  if (count(finest) <= max_samples) return finest;
  if (count(coarsest) > max_samples) return coarsest;
  double lo = finest, hi = coarsest;  // count(lo) > max_samples >= count(hi)
  while (hi > lo * (1 + 1e-3)) {
    const double mid = std::sqrt(lo * hi);
    (count(mid) <= max_samples ? hi : lo) = mid;
  }
  return hi;
}

template <int D>
SurfaceDistances surface_distances(SurfaceRef<D> a, SurfaceRef<D> b, double sample_spacing, int64_t max_samples) {
  DSNAKE_ASSERT(sample_spacing > 0, "sample spacing is positive");
  const FacetSurface<D> fa = facets_of(a), fb = facets_of(b);
  const FacetGrid<D> ga(fa), gb(fb);
  // One surface's samples at a time (directed_distances).
  const DirectedDistances da =
      directed_distances(gb, sample_surface(fa, surface_spacing(fa, sample_spacing, max_samples), batch_block(gb)));
  const DirectedDistances db =
      directed_distances(ga, sample_surface(fb, surface_spacing(fb, sample_spacing, max_samples), batch_block(ga)));
  return summarize(da, db);
}

template <int D>
SurfaceDistances surface_distances_to_mask(SurfaceRef<D> a, const BinaryMask<D>& mask, double sample_spacing,
                                           int64_t max_samples) {
  DSNAKE_ASSERT(sample_spacing > 0, "sample spacing is positive");
  const FacetSurface<D> fa = facets_of(a);
  const MaskBoundary<D> boundary = mask_boundary(mask);
  const Point<D>& spacing = mask.spacing();
  const FacetGrid<D> ga(fa), gb(boundary.surface);
  const DirectedDistances da =
      directed_distances(gb, sample_surface(fa, surface_spacing(fa, sample_spacing, max_samples), batch_block(gb)));
  const DirectedDistances db = directed_distances(
      ga, sample_mask_boundary(boundary, spacing, mask_spacing(boundary, spacing, sample_spacing, max_samples)));
  return summarize(da, db);
}

template <int D>
Image<D> rasterize_interior(SurfaceRef<D> s, const Grid<D>& grid) {
  DSNAKE_ASSERT(int(s.points.size()) == s.connectivity.num_vertices(), "one position per vertex");
  DSNAKE_ASSERT(s.connectivity.is_polygon() == (D == 2), "polygon in 2D, mesh in 3D");
  return rasterize(s, grid, VoxelRange<D>{GridIndex<D>::Zero(), grid.size});
}

template <int D>
double dice_against_mask(SurfaceRef<D> s, const BinaryMask<D>& mask) {
  DSNAKE_ASSERT(int(s.points.size()) == s.connectivity.num_vertices(), "one position per vertex");
  DSNAKE_ASSERT(s.connectivity.is_polygon() == (D == 2), "polygon in 2D, mesh in 3D");
  const Grid<D>& g = mask.grid();
  const VoxelRange<D> truth = nonzero_voxels(mask), box = union_of(truth, voxels_around(s.points, g));
  int64_t in_mask = 0, in_snake = 0, both = 0;
  for (int64_t l = 0; l < mask.num_voxels(); ++l) in_mask += mask[l];
  if (box.num_voxels() > 0) {
    const Image<D> inside = rasterize(s, g, box);
    const Grid<D>& sub = inside.grid();
    const int nx = box.size[0];
    for (int64_t row = 0; row < inside.num_voxels(); row += nx) {  // a row of the box along x
      const float* in_row = inside.data().data() + row;
      const uint8_t* mask_row = mask.data().data() + g.linear(sub.index(row) + box.lo);
      for (int i = 0; i < nx; ++i) {
        in_snake += in_row[i] != 0.0f;
        both += in_row[i] != 0.0f && mask_row[i] != 0;
      }
    }
  }
  return in_mask + in_snake == 0 ? 1.0 : 2.0 * double(both) / double(in_mask + in_snake);
}

template <int D>
SurfaceDistances surface_distances_to_mask(SurfaceRef<D> a, const Image<D>& mask, double sample_spacing,
                                           int64_t max_samples) {
  return surface_distances_to_mask(a, BinaryMask<D>(mask), sample_spacing, max_samples);
}

template <int D>
double dice_against_mask(SurfaceRef<D> s, const Image<D>& mask) {
  return dice_against_mask(s, BinaryMask<D>(mask));
}

template <int D>
double dice(const Image<D>& a, const Image<D>& b) {
  DSNAKE_ASSERT(a.grid().same_geometry(b.grid()), "dice needs two masks on the same grid");
  int64_t na = 0, nb = 0, both = 0;
  for (int64_t i = 0; i < a.num_voxels(); ++i) {
    const bool ia = a[i] != 0.0f, ib = b[i] != 0.0f;
    na += ia;
    nb += ib;
    both += ia && ib;
  }
  return na + nb == 0 ? 1.0 : 2.0 * double(both) / double(na + nb);
}

template <int D>
CorrespondenceError correspondence_error(const Snake<D>& snake,
                                         const std::vector<std::optional<Point<D>>>& targets) {
  CorrespondenceError e;
  e.per_vertex.assign(targets.size(), kNaN);
  double sum = 0;
  for (size_t t = 0; t < targets.size(); ++t) {
    const int v = snake.vertex_of_template_id(int(t));
    if (!targets[t] || v < 0) continue;
    const double d = (snake.positions()[v] - *targets[t]).norm();
    e.per_vertex[t] = d;
    sum += d;
    e.max = std::max(e.max, d);
    ++e.count;
  }
  e.mean = e.count ? sum / e.count : 0.0;
  return e;
}

// Only pairs of facets that share no vertex are tested: pairs that share a vertex (or an edge)
// and overlap elsewhere, e.g. folded neighbours, are not counted.
template <int D>
int count_self_intersections(SurfaceRef<D> s) {
  const FacetSurface<D> fs = facets_of(s);
  const FacetGrid<D> grid(fs);
  const int n = grid.num_facets();
  int count = 0;
#pragma omp parallel reduction(+ : count)
  {
    auto scratch = grid.make_scratch();
    std::vector<int> candidates;
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < n; ++i) {
      grid.overlapping_facets(i, scratch, candidates);
      for (int j : candidates) {
        if (share_vertex<D>(fs.facets[i], fs.facets[j])) continue;
        const auto& p = grid.corners(i);
        const auto& q = grid.corners(j);
        bool hit;
        if constexpr (D == 2) {
          hit = segments_intersect(p[0], p[1], q[0], q[1]);
        } else {
          hit = triangles_intersect(p, q);
        }
        count += hit;
      }
    }
  }
  return count;
}

template <int D>
Metrics compute_metrics(const Snake<D>& snake, const GroundTruth<D>& truth, const MetricsOptions& options) {
  Metrics m;
  const SurfaceRef<D> shape{snake.positions(), snake.connectivity()};
  const bool has_inside = truth.mask && std::any_of(truth.mask->data().begin(), truth.mask->data().end(),
                                                    [](uint8_t v) { return v != 0; });
  double h = options.sample_spacing;
  if (!(h > 0)) h = truth.mask ? truth.mask->spacing().minCoeff() / 5.0 : 0.2;
  const int64_t cap = options.max_samples;

  std::optional<SurfaceDistances> sd;
  if (truth.surface) {
    sd = surface_distances<D>(shape, {truth.surface->positions, truth.surface->connectivity}, h, cap);
  } else if (has_inside) {
    sd = surface_distances_to_mask<D>(shape, *truth.mask, h, cap);
  }
  if (sd && std::isfinite(sd->hausdorff)) {
    m.mean_surface_distance = sd->mean;
    m.hausdorff95 = sd->hausdorff95;
    m.hausdorff = sd->hausdorff;
  }
  if (truth.mask) m.dice = dice_against_mask<D>(shape, *truth.mask);
  if (std::any_of(truth.targets.begin(), truth.targets.end(), [](const auto& t) { return t.has_value(); })) {
    const CorrespondenceError ce = correspondence_error<D>(snake, truth.targets);
    if (ce.count > 0) {
      m.correspondence_error_mean = ce.mean;
      m.correspondence_error_max = ce.max;
    }
  }
  m.self_intersections = count_self_intersections<D>(shape);
  return m;
}

#define DSNAKE_INSTANTIATE_METRICS(D)                                                            \
  template std::vector<double> distances_to_surface<D>(SurfaceRef<D>, const PointList<D>&);      \
  template SurfaceDistances surface_distances<D>(SurfaceRef<D>, SurfaceRef<D>, double, int64_t);          \
  template SurfaceDistances surface_distances_to_mask<D>(SurfaceRef<D>, const BinaryMask<D>&, double, int64_t); \
  template SurfaceDistances surface_distances_to_mask<D>(SurfaceRef<D>, const Image<D>&, double, int64_t); \
  template Image<D> rasterize_interior<D>(SurfaceRef<D>, const Grid<D>&);                        \
  template double dice_against_mask<D>(SurfaceRef<D>, const BinaryMask<D>&);                     \
  template double dice_against_mask<D>(SurfaceRef<D>, const Image<D>&);                          \
  template double dice<D>(const Image<D>&, const Image<D>&);                                     \
  template CorrespondenceError correspondence_error<D>(const Snake<D>&,                          \
                                                       const std::vector<std::optional<Point<D>>>&); \
  template int count_self_intersections<D>(SurfaceRef<D>);                                       \
  template Metrics compute_metrics<D>(const Snake<D>&, const GroundTruth<D>&, const MetricsOptions&);

DSNAKE_INSTANTIATE_METRICS(2)
DSNAKE_INSTANTIATE_METRICS(3)

}  // namespace dsnake
