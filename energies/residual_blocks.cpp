// Ceres cost functions for the deformation energies; see residual_blocks.h.
#include "energies/residual_blocks.h"

#include "framework/errors.h"

#include <ceres/ceres.h>
#include <cmath>

namespace dsnake {

namespace {

// r = scale * sum_k C_k q_k, Jacobian dr/dq_k = scale * C_k (row-major for Ceres).
template <int D>
class BlockLinearCost : public ceres::CostFunction {
 public:
  BlockLinearCost(std::vector<Block<D>> blocks, double scale) : blocks_(std::move(blocks)), scale_(scale) {
    set_num_residuals(D);
    for (size_t k = 0; k < blocks_.size(); ++k) mutable_parameter_block_sizes()->push_back(D);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Point<D> r = Point<D>::Zero();
    for (size_t k = 0; k < blocks_.size(); ++k) r += blocks_[k] * Eigen::Map<const Point<D>>(parameters[k]);
    for (int a = 0; a < D; ++a) residuals[a] = scale_ * r[a];
    if (jacobians)
      for (size_t k = 0; k < blocks_.size(); ++k)
        if (jacobians[k])
          for (int a = 0; a < D; ++a)
            for (int b = 0; b < D; ++b) jacobians[k][a * D + b] = scale_ * blocks_[k](a, b);
    return true;
  }

 private:
  std::vector<Block<D>> blocks_;
  double scale_;
};

// A residual function of several vertex positions; Jacobian by central differences with a step
// relative to the coordinate's size (error O(h^2) ~ 1e-10 relative for smooth terms).
template <int D>
class NumericCost : public ceres::CostFunction {
 public:
  NumericCost(int num_vertices, int num_residuals, ResidualFunction<D> f) : f_(std::move(f)), m_(num_vertices) {
    set_num_residuals(num_residuals);
    for (int k = 0; k < num_vertices; ++k) mutable_parameter_block_sizes()->push_back(D);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    PointList<D> q(m_);
    for (int k = 0; k < m_; ++k) q[k] = Eigen::Map<const Point<D>>(parameters[k]);
    f_(q, residuals);
    if (!jacobians) return true;
    const int nr = num_residuals();
    std::vector<double> plus(nr), minus(nr);
    for (int k = 0; k < m_; ++k) {
      if (!jacobians[k]) continue;
      for (int b = 0; b < D; ++b) {
        const double x = q[k][b], h = 1e-6 * (1.0 + std::abs(x));
        q[k][b] = x + h;
        f_(q, plus.data());
        q[k][b] = x - h;
        f_(q, minus.data());
        q[k][b] = x;
        for (int a = 0; a < nr; ++a) jacobians[k][a * D + b] = (plus[a] - minus[a]) / (2 * h);
      }
    }
    return true;
  }

 private:
  ResidualFunction<D> f_;
  int m_;
};

}  // namespace

template <int D>
void add_block_linear_residual(GlobalProblem<D>& problem, const std::vector<int>& vertices,
                               const std::vector<Block<D>>& blocks, double scale) {
  DSNAKE_ASSERT(vertices.size() == blocks.size() && !vertices.empty(), "one block per vertex");
  problem.add_residual_block(new BlockLinearCost<D>(blocks, scale), vertices);
}

template <int D>
void add_numeric_residual(GlobalProblem<D>& problem, const std::vector<int>& vertices, int num_residuals,
                          ResidualFunction<D> residual) {
  DSNAKE_ASSERT(!vertices.empty() && num_residuals > 0, "a non-empty residual block");
  problem.add_residual_block(new NumericCost<D>(int(vertices.size()), num_residuals, std::move(residual)), vertices);
}

template void add_block_linear_residual<2>(GlobalProblem<2>&, const std::vector<int>&, const std::vector<Block<2>>&, double);
template void add_block_linear_residual<3>(GlobalProblem<3>&, const std::vector<int>&, const std::vector<Block<3>>&, double);
template void add_numeric_residual<2>(GlobalProblem<2>&, const std::vector<int>&, int, ResidualFunction<2>);
template void add_numeric_residual<3>(GlobalProblem<3>&, const std::vector<int>&, int, ResidualFunction<3>);

}  // namespace dsnake
