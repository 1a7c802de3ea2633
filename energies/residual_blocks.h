// Residual blocks shared by the deformation energies' global view (Ceres stays in the .cpp):
//  - block-linear residuals r = scale * sum_k C_k q_{v_k} with D x D blocks C_k (exact Jacobian);
//  - general residuals r(q_{v_0}, ..., q_{v_m}) given as a function, with a central-difference
//    Jacobian (for terms whose optimal rotation is eliminated in closed form: 3D ASAP, ARAP).
#pragma once

#include "framework/global_problem.h"

#include <Eigen/Core>
#include <functional>
#include <vector>

namespace dsnake {

template <int D>
using Block = Eigen::Matrix<double, D, D>;

template <int D>
void add_block_linear_residual(GlobalProblem<D>& problem, const std::vector<int>& vertices,
                               const std::vector<Block<D>>& blocks, double scale);

// residual(q, r): q holds the listed vertices' positions in order, r has num_residuals entries.
template <int D>
using ResidualFunction = std::function<void(const PointList<D>& q, double* r)>;

template <int D>
void add_numeric_residual(GlobalProblem<D>& problem, const std::vector<int>& vertices, int num_residuals,
                          ResidualFunction<D> residual);

}  // namespace dsnake
