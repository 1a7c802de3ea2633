// Shared geometry of the deformation energies (Levi & Gotsman, D-Snake, §4 and Appendix):
//  - MLS neighbourhoods and the normalised weights of eq. (2) over the template vertices;
//  - the weighted best similarity (2D closed form, 3D SVD, reflection-safe) and best rotation.
#pragma once

#include "framework/shape.h"

#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

namespace dsnake {

enum class NeighborhoodKind { kAll, kNearest, kRings };

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
  double falloff = 1.0; // eq. (2)'s fall-off exponent (> 0)
  bool uniform = false; // w~ = 1 (the global similarity of eq. (3) when kind = kAll)
};

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
