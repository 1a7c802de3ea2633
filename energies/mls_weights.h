// Shared geometry of the deformation energies (Levi & Gotsman, D-Snake, §4 and Appendix):
//  - MLS neighbourhoods and the normalised weights of eq. (2) over the template vertices;
//  - the weighted best similarity (2D closed form, 3D SVD, reflection-safe) and best rotation.
#pragma once

#include "framework/core/options.h"
#include "framework/core/shape.h"

#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

namespace dsnake {

enum class NeighborhoodKind { kAll, kNearest, kRings };
template <>
struct EnumNames<NeighborhoodKind> {
  static constexpr std::array<std::pair<NeighborhoodKind, const char*>, 3> table{
      {{NeighborhoodKind::kAll, "all"}, {NeighborhoodKind::kNearest, "k_nearest"}, {NeighborhoodKind::kRings, "rings"}}};
};
// eq. (2)'s weights w~_ij = |p_i - p_j|^(-2 falloff), or 1 (eq. (3)'s w = 1).
enum class MlsWeighting { kInverseDistance, kUniform };
template <>
struct EnumNames<MlsWeighting> {
  static constexpr std::array<std::pair<MlsWeighting, const char*>, 2> table{
      {{MlsWeighting::kInverseDistance, "inverse_distance"}, {MlsWeighting::kUniform, "uniform"}}};
};

// For every template vertex j, its neighbours i != j and their weights w_ij of eq. (2):
//   w~_ij = |p_i - p_j|^(-2 falloff)  (or 1 when `uniform`: eq. (3)'s w = 1),  w_ij = w~_ij / sum_i w~_ij.
// Neighbours that coincide with p_j (|p_i - p_j| <= 1e-12 x bounding-box diagonal) are left out:
// their weight would be infinite (the degenerate-template fallback).
struct MlsNeighborhoods {
  std::vector<int> offsets{0};  // CSR over j
  std::vector<int> index;       // template ids i
  std::vector<double> weight;   // w_ij, summing to 1 over each non-empty neighbourhood

  int size() const { return int(offsets.size()) - 1; }
  std::span<const int> neighbors(int j) const { return {index.data() + offsets[j], index.data() + offsets[j + 1]}; }
  std::span<const double> weights(int j) const { return {weight.data() + offsets[j], weight.data() + offsets[j + 1]}; }
};

struct NeighborhoodSpec {
  NeighborhoodKind kind = NeighborhoodKind::kRings;
  int k = 8;            // kNearest: number of nearest template vertices (Euclidean, template positions)
  int rings = 1;        // kRings: vertices within this many edges on the template connectivity
  // kRings: the template size (vertices) at which `rings` is meant, or 0 for `rings` as given. A
  // ring's width is the template's edge length, so a fixed count covers less of the surface on a
  // finer template; with n vertices the count is scaled to the same share of the surface (3D,
  // edge length ~ n^(-1/2)) or of the outline (2D, ~ n^(-1)). effective_rings() gives it.
  int rings_at_vertices = 0;
  double falloff = 1.0; // eq. (2)'s fall-off exponent (> 0)
  MlsWeighting weights = MlsWeighting::kInverseDistance;  // kUniform: the global similarity of eq. (3) when kind = kAll

  template <class V>
  void visit(V& v) {
    v(kind, Key{"neighborhood", "", "N(j): every template vertex, the k nearest, or the vertices within `rings` edges"});
    v(k, Key{"k", "vertices", "k_nearest: number of nearest template vertices (at most the template's size - 1)", Range::at_least(1)});
    v(rings, Key{"rings", "edges", "rings: the neighbourhood's radius on the template connectivity", Range::at_least(1)});
    v(rings_at_vertices, Key{"rings_at_vertices", "vertices",
                             "rings: the template size at which `rings` is meant; a template of n vertices then uses "
                             "round(rings (n / rings_at_vertices)^(1/(D-1))) rings, at least 1: the same share of its "
                             "surface (3D) or outline (2D) at every resolution. 0: `rings` as given",
                             Range::at_least(0)});
    v(falloff, Key{"falloff", "1", "eq. (2)'s fall-off exponent", Range::greater_than(0)});
    v(weights, Key{"weights", "", "eq. (2)'s inverse-distance weights or uniform ones (eq. (3))"});
  }
};

// The ring count a kRings neighbourhood uses on a template of n vertices: spec.rings, or with
// spec.rings_at_vertices > 0, round(rings (n / rings_at_vertices)^(1/(D-1))) and at least 1.
template <int D>
int effective_rings(const NeighborhoodSpec& spec, int n);

template <int D>
MlsNeighborhoods build_neighborhoods(const Template<D>& tmpl, const NeighborhoodSpec& spec);

// Linear part M = mu R (mu >= 0, det R = +1) of the similarity minimising
// sum_i w_i |M a_i + t - b_i|^2 for centred data, given the cross-covariance
// cross = sum_i w_i b_i a_i^T and spread = sum_i w_i |a_i|^2 (Appendix; Umeyama's sign fix for
// reflections). spread <= tiny (all a_i coincide): M = 0, the defined degenerate fallback.
template <int D>
Eigen::Matrix<double, D, D> best_similarity(const Eigen::Matrix<double, D, D>& cross, double spread);

// The rotation R (det +1) maximising trace(R^T cross) (ARAP, Sorkine & Alexa 2007); identity for
// cross = 0.
template <int D>
Eigen::Matrix<double, D, D> best_rotation(const Eigen::Matrix<double, D, D>& cross);

// The snake vertex of every template id 0..n-1, into vertex_of_id (n entries). Every template
// vertex is on the snake: remeshers never remove a deformation vertex (remesher.h).
template <int D>
void map_template_vertices(const Snake<D>& snake, int n, std::vector<int>& vertex_of_id);

}  // namespace dsnake
