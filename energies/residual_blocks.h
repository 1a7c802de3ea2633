// Residual blocks shared by the deformation energies' global view (Ceres stays in the .cpp):
//  - block-linear residuals r = scale * sum_k C_k q_{v_k} with D x D blocks C_k (exact Jacobian);
//  - transform residuals r_k = c_k (S a_k - (q_{v_k} - q_centre)) with a per-centre rotation or
//    similarity S as an auxiliary parameter block (ASAP's T_j of §4, ARAP's R_i), with
//    automatic derivatives. S is an angle (2D) or a unit quaternion (3D, Ceres' quaternion
//    manifold), times e^sigma for a similarity.
#pragma once

#include "framework/global/global_problem.h"
#include "framework/core/potential.h"

#include <Eigen/Core>
#include <vector>

namespace dsnake {

template <int D>
using Block = Eigen::Matrix<double, D, D>;

template <int D>
void add_block_linear_residual(GlobalProblem<D>& problem, const std::vector<int>& vertices,
                               const std::vector<Block<D>>& blocks, double scale);

// Adds one auxiliary block S for `centre`, initialised to `initial` (a rotation, or mu R with
// mu > 0 for a similarity), and the residuals r_k = scales[k] (S a[k] - (q_{others[k]} - q_centre)).
template <int D>
void add_transform_residuals(GlobalProblem<D>& problem, int centre, const std::vector<int>& others,
                             const PointList<D>& a, const std::vector<double>& scales, bool with_scale,
                             const Block<D>& initial);

// Adds the D residuals r = scale (q_v - target) (a spring to a fixed point; Jacobian scale I).
template <int D>
void add_anchor_residual(GlobalProblem<D>& problem, int v, const Point<D>& target, double scale);

// Adds r = sqrt(weight (P(q_v) + 1e-12)) for vertex v (the offset keeps the square root
// differentiable where P = 0), with the exact derivative weight grad P / (2 r).
template <int D>
void add_potential_residual(GlobalProblem<D>& problem, int v, const Potential<D>& potential, double weight);

}  // namespace dsnake
