#include "framework/global_problem.h"

#include "framework/errors.h"

#include <ceres/ceres.h>

namespace dsnake {

namespace {

// r = scale * sum_k c_k q_{v_k}: D residuals, one parameter block of D per listed vertex, with
// the constant Jacobian dr/dq_{v_k} = scale * c_k * I.
template <int D>
class LinearResidual : public ceres::CostFunction {
 public:
  LinearResidual(std::vector<double> coefficients, double scale) : coefficients_(std::move(coefficients)), scale_(scale) {
    set_num_residuals(D);
    for (size_t k = 0; k < coefficients_.size(); ++k) mutable_parameter_block_sizes()->push_back(D);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    for (int a = 0; a < D; ++a) residuals[a] = 0.0;
    for (size_t k = 0; k < coefficients_.size(); ++k)
      for (int a = 0; a < D; ++a) residuals[a] += scale_ * coefficients_[k] * parameters[k][a];
    if (jacobians)
      for (size_t k = 0; k < coefficients_.size(); ++k) {
        if (!jacobians[k]) continue;
        for (int r = 0; r < D; ++r)
          for (int c = 0; c < D; ++c) jacobians[k][r * D + c] = r == c ? scale_ * coefficients_[k] : 0.0;
      }
    return true;
  }

 private:
  std::vector<double> coefficients_;
  double scale_;
};

}  // namespace

template <int D>
struct GlobalProblem<D>::Impl {
  std::vector<double> parameters;  // n x D, vertex-major
  ceres::Problem problem;
  int num_vertices = 0;
};

template <int D>
GlobalProblem<D>::GlobalProblem(const Snake<D>& snake) : impl_(std::make_unique<Impl>()) {
  impl_->num_vertices = snake.num_vertices();
  impl_->parameters.resize(size_t(snake.num_vertices()) * D);
  for (int v = 0; v < snake.num_vertices(); ++v)
    for (int a = 0; a < D; ++a) impl_->parameters[size_t(v) * D + a] = snake.positions()[v][a];
  for (int v = 0; v < snake.num_vertices(); ++v) impl_->problem.AddParameterBlock(vertex(v), D);
}

template <int D>
GlobalProblem<D>::~GlobalProblem() = default;

template <int D>
void GlobalProblem<D>::add_linear_residual(std::span<const int> vertices, std::span<const double> coefficients,
                                           double scale) {
  DSNAKE_ASSERT(vertices.size() == coefficients.size() && !vertices.empty(), "one coefficient per vertex");
  add_residual_block(new LinearResidual<D>({coefficients.begin(), coefficients.end()}, scale),
                     {vertices.begin(), vertices.end()});
}

template <int D>
void GlobalProblem<D>::add_residual_block(ceres::CostFunction* cost, const std::vector<int>& vertices) {
  std::vector<double*> blocks;
  for (int v : vertices) {
    DSNAKE_ASSERT(v >= 0 && v < impl_->num_vertices, "vertex in range");
    blocks.push_back(vertex(v));
  }
  impl_->problem.AddResidualBlock(cost, nullptr, blocks);
}

template <int D>
int GlobalProblem<D>::num_vertices() const { return impl_->num_vertices; }

template <int D>
int GlobalProblem<D>::num_residual_blocks() const { return impl_->problem.NumResidualBlocks(); }

template <int D>
double* GlobalProblem<D>::vertex(int v) { return impl_->parameters.data() + size_t(v) * D; }

template <int D>
PointList<D> GlobalProblem<D>::positions() const {
  PointList<D> q(impl_->num_vertices);
  for (int v = 0; v < impl_->num_vertices; ++v)
    for (int a = 0; a < D; ++a) q[v][a] = impl_->parameters[size_t(v) * D + a];
  return q;
}

template <int D>
double GlobalProblem<D>::sum_of_squares() const {
  double cost = 0.0;
  impl_->problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
  return 2.0 * cost;
}

template <int D>
ceres::Problem& GlobalProblem<D>::problem() { return impl_->problem; }

template class GlobalProblem<2>;
template class GlobalProblem<3>;

}  // namespace dsnake
