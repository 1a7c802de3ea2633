// Discrete operators on a snake's connectivity (2D polygon or 3D triangle mesh), shared by the
// energies, the meshing and any plug-in that needs them, so that each is written once:
//  - the umbrella Laplacian (uniform weights), (L q)_i = q_i - (1 / |N(i)|) sum_{j in N(i)} q_j
//    with N(i) the one-ring of i: the internal energy's L of D-Snake §1 and §3.1, the
//    delta-coordinates of Sorkine et al., "Laplacian surface editing" (2004), and Taubin's
//    smoothing step ("A signal processing approach to fair surface design", 1995);
//  - the piecewise-linear elements' operators at the current positions: the lumped mass M (2D
//    half of each adjacent edge's length, 3D the mixed Voronoi areas of Meyer, Desbrun, Schroeder,
//    Barr, "Discrete differential-geometry operators for triangulated 2-manifolds", 2003) and the
//    stiffness K (2D 1 / l per edge, 3D the cotangent Laplacian K_ij = -1/2 (cot a_ij + cot b_ij)),
//    with degenerate elements' lengths and areas floored (kRelativeMeasureFloor).
// Sums run in a fixed order (the one-ring's order; elements in order), so that results do not
// depend on the caller or the thread count.
#pragma once

#include "framework/core/shape.h"

#include <Eigen/SparseCore>
#include <vector>

namespace dsnake {

// --- The umbrella Laplacian --------------------------------------------------------------------

// The mean of v's one-ring at positions q (n x D): the neighbours summed in the ring's order,
// then divided by their count. v must have a neighbour.
template <int D>
Point<D> one_ring_mean(const Connectivity& c, const PointList<D>& q, int v);

// (L q)_v = q_v - one_ring_mean(c, q, v); zero for an isolated vertex.
template <int D>
Point<D> umbrella_laplacian(const Connectivity& c, const PointList<D>& q, int v);

// v's weight in the umbrella's normalisation, L = W^{-1} Lc with W = diag(weights): its valence,
// 1 for an isolated vertex (whose row of L is zero).
double umbrella_weight(const Connectivity& c, int v);

// The combinatorial Laplacian Lc = diag(valence) - adjacency (n x n, symmetric positive
// semi-definite), so that the umbrella L = W^{-1} Lc.
Eigen::SparseMatrix<double> combinatorial_laplacian(const Connectivity& c);

// --- Piecewise-linear elements: lumped mass and stiffness ---------------------------------------

// Floors of degenerate elements, relative to the mean edge length l (lengths) and l^2 (areas).
constexpr double kRelativeMeasureFloor = 1e-3;

// The elements, D vertices each (n_elements D entries): 2D the polygon's edges (v, v + 1 mod n),
// 3D the triangles.
template <int D>
std::vector<int> element_vertices(const Connectivity& c);

// The floor of an element's measure (2D length, 3D area): kRelativeMeasureFloor times the mean
// edge length (squared in 3D), or 1 when every edge has zero length.
template <int D>
double element_measure_floor(const PointList<D>& q, const std::vector<int>& elements);

// Triangle t = (a, b, c) of q: e[i] the edge opposite vertex i (e0 = c - b, e1 = a - c, e2 = b - a)
// and its area, at least `floor`.
void triangle_edges(const PointList<3>& q, const int* t, double floor, Point<3> (&e)[3], double& area);

// The mixed Voronoi area of each corner of a triangle with edges e (as triangle_edges gives
// them) and area `area` (Meyer et al. 2003, fig. 4): the Voronoi region's part
// 1/8 (|e_l|^2 cot(angle l) + |e_j|^2 cot(angle j)) in a non-obtuse triangle, area / 2 at an
// obtuse angle and area / 4 at the other two. The parts sum to the area.
void mixed_voronoi_areas(const Point<3> (&e)[3], double area, double (&part)[3]);

// Each element's local stiffness into `local` (D x D per element, row-major; 2D (1 / l) [1 -1; -1 1],
// 3D e_i . e_j / (4 A), the cotangent Laplacian's element matrix) and, with `with_mass`, the
// lumped mass into `mass` (one per vertex of q: 2D l / 2 to each end, 3D the mixed Voronoi
// areas), lengths and areas floored and every vertex mass at least the floor (also a vertex in
// no element: M^-1 has no NaN). `local` and `mass` are resized (no allocation once they have
// their size); without mass, `mass` is left empty.
template <int D>
void element_stiffness_and_mass(const PointList<D>& q, const std::vector<int>& elements, std::vector<double>& local,
                                std::vector<double>& mass, bool with_mass = true);

// The assembled stiffness K (n x n, symmetric; the cotangent Laplacian in 3D) of the snake's
// positions over `elements`, and the lumped mass into `mass`.
template <int D>
Eigen::SparseMatrix<double> stiffness_matrix(const Snake<D>& snake, const std::vector<int>& elements,
                                             std::vector<double>& mass);

}  // namespace dsnake
