// A uniform grid (with a bounding-volume tree for far queries) over the facets of a boundary:
// exact point-to-facet distances (the surface distances and HD95 of framework/metrics/metrics.h)
// and the broad-phase search of facet pairs whose boxes overlap (the self-intersection count).
#pragma once

#include "framework/core/types.h"
#include "framework/geometry/predicates.h"

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace dsnake {

// A facet with what its exact distance test needs, precomputed: its corners v, edge vectors
// e[k] = v[k+1] - v[k] with their inverse squared lengths, and for a triangle its normal n,
// 1 / |n|^2 (0 if degenerate) and in-plane edge normals m[k] = n x e[k].
template <int D>
struct PreparedFacet {
  std::array<Point<D>, D> v, e, m;
  std::array<double, D> inv_len2;
  Point<D> n;
  double inv_nn = 0;
};

// Uniform grid of cells over a surface's facets; each facet is listed in every cell that its
// bounding box overlaps. Cells are about one facet wide, capped at ~8 cells per facet.
template <int D>
class FacetGrid {
 public:
  explicit FacetGrid(const FacetSurface<D>& surface);

  // Per-thread query state: visit stamps (each facet tested once per query) and the facet
  // found nearest by the previous query, a tight first bound for nearby query points.
  struct Scratch {
    std::vector<uint32_t> stamp;
    uint32_t query = 0;
    int hint = -1;
    std::vector<std::pair<double, int>> candidates;  // batch queries: (box gap, facet)
  };
  Scratch make_scratch() const;

  int num_facets() const { return static_cast<int>(prepared_.size()); }
  double cell_size() const { return cell_; }  // physical units

  // Exact distance from p (anywhere, inside the grid or not) to the nearest facet: rings of
  // cells around p's cell, skipping cells and facets whose box is farther than the best
  // distance so far, until the unvisited region is provably farther; past two rings, or for a
  // point far outside the grid, the facet tree finishes the search. Infinity if no facets.
  double distance(const Point<D>& p, Scratch& scratch) const;

  // Exact distances from points that lie close together (e.g. the samples of one facet) to
  // the nearest facets, into out[0 .. count). The facet nearest to the batch's centre bounds
  // every point's distance by U; the facets whose boxes are within U of the batch's box are
  // gathered once, sorted by that gap, and each point tests them until the gap exceeds its
  // best distance. Far-spread batches fall back to distance().
  void batch_distances(const Point<D>* points, int64_t count, double* out, Scratch& scratch) const;

  // Exact distance from p to facet f, by testing it directly.
  double facet_distance(const Point<D>& p, int f) const;
  double facet_distance2(const Point<D>& p, int f) const;  // squared, from prepared_

  // Every facet j > i whose bounding box overlaps that of facet i, each once (broad phase).
  void overlapping_facets(int i, Scratch& scratch, std::vector<int>& out) const;

  const std::array<Point<D>, D>& corners(int f) const { return prepared_[f].v; }

 private:
  GridIndex<D> cell_of(const Point<D>& x) const;  // clamped to the grid
  int64_t linear(const GridIndex<D>& c) const;
  double cell_box_distance2(const Point<D>& p, const GridIndex<D>& c) const;
  uint32_t next_query(Scratch& s) const;  // new visit stamp (clears stamps on wrap-around)
  void visit_cell(const Point<D>& p, const GridIndex<D>& c, Scratch& s, double& best) const;

  std::vector<PreparedFacet<D>> prepared_;        // facet corners and their test data
  std::vector<Point<D>> box_lo_, box_hi_;          // facet bounding boxes
  Point<D> lo_ = Point<D>::Zero();                 // grid corner, physical units
  double cell_ = 1;                                // cell edge length, physical units
  GridIndex<D> dims_ = GridIndex<D>::Ones();       // cells per axis
  double tolerance_ = 0;                           // slack on pruning tests (rounding)
  std::vector<int64_t> offsets_;                   // CSR: facets of cell c are
  std::vector<int> cell_facets_;                   // cell_facets_[offsets_[c] .. offsets_[c+1])

  // A bounding-volume hierarchy over the same facets, for the queries the grid answers badly:
  // a point far from every facet (a collapsed or distant surface, or a point deep inside a
  // large one), whose ring walk would visit O((distance / cell)^D) empty cells. A
  // leaf is a box over tree_facets_[first .. first + count); inner nodes split their facets at
  // the median of the facet centres along the centres' longest axis (depth <= log2(facets) + 1).
  struct TreeNode {
    Point<D> lo, hi;
    int first = 0;  // leaf: its first entry in tree_facets_; inner: the left child (right: first + 1)
    int count = 0;  // leaf: its facets; inner: 0
  };
  void build_tree();
  // Lowers best (and s.hint) to the exact distance from p to the nearest facet, visiting only
  // nodes whose box is within best (+ the rounding slack) of p.
  void tree_distance(const Point<D>& p, Scratch& s, double& best) const;
  std::vector<TreeNode> tree_;
  std::vector<int> tree_facets_;
};

}  // namespace dsnake
