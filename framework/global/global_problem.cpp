#include "framework/global/global_problem.h"

#include "framework/core/errors.h"

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <deque>

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

// Forwards Ceres' per-iteration callback to the caller's function.
class ForwardingCallback : public ceres::IterationCallback {
 public:
  explicit ForwardingCallback(const std::function<bool(int)>& f) : f_(f) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    return f_(summary.iteration) ? ceres::SOLVER_CONTINUE : ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }

 private:
  const std::function<bool(int)>& f_;
};

std::string termination_name(ceres::TerminationType t) {
  switch (t) {
    case ceres::CONVERGENCE: return "convergence";
    case ceres::NO_CONVERGENCE: return "no_convergence";
    case ceres::USER_SUCCESS: return "stopped";
    default: return "failure";
  }
}

}  // namespace

template <int D>
struct GlobalProblem<D>::Impl {
  std::vector<double> parameters;  // n x D, vertex-major
  std::deque<std::vector<double>> auxiliary;  // stable addresses
  std::vector<bool> eliminated;                // per auxiliary block: in the first Schur group
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
int GlobalProblem<D>::add_auxiliary_block(std::span<const double> initial, AuxiliaryKind kind) {
  auto& block = impl_->auxiliary.emplace_back(initial.begin(), initial.end());
  const int size = int(block.size());
  impl_->eliminated.push_back(kind != AuxiliaryKind::kSharedEuclidean);
  switch (kind) {
    case AuxiliaryKind::kEuclidean:
    case AuxiliaryKind::kSharedEuclidean:
      impl_->problem.AddParameterBlock(block.data(), size);
      break;
    case AuxiliaryKind::kQuaternion:
      DSNAKE_ASSERT(size == 4, "a quaternion block has 4 entries");
      impl_->problem.AddParameterBlock(block.data(), size, new ceres::QuaternionManifold());
      break;
    case AuxiliaryKind::kQuaternionAndScale:
      DSNAKE_ASSERT(size == 5, "a quaternion-and-scale block has 5 entries");
      impl_->problem.AddParameterBlock(
          block.data(), size,
          new ceres::ProductManifold<ceres::QuaternionManifold, ceres::EuclideanManifold<1>>{});
      break;
  }
  return int(impl_->auxiliary.size()) - 1;
}

template <int D>
void GlobalProblem<D>::add_residual_block(ceres::CostFunction* cost, const std::vector<int>& auxiliary,
                                          const std::vector<int>& vertices) {
  std::vector<double*> blocks;
  for (int b : auxiliary) {
    DSNAKE_ASSERT(b >= 0 && b < int(impl_->auxiliary.size()), "auxiliary block in range");
    blocks.push_back(impl_->auxiliary[b].data());
  }
  for (int v : vertices) {
    DSNAKE_ASSERT(v >= 0 && v < impl_->num_vertices, "vertex in range");
    blocks.push_back(vertex(v));
  }
  impl_->problem.AddResidualBlock(cost, nullptr, blocks);
}

template <int D>
int GlobalProblem<D>::num_auxiliary_blocks() const { return int(impl_->auxiliary.size()); }

template <int D>
double* GlobalProblem<D>::auxiliary(int b) { return impl_->auxiliary[b].data(); }

// Ceres' trust-region (Levenberg-Marquardt) solve. With sparse Schur, the auxiliary blocks are
// eliminated first (each residual touches at most one of them), like points in bundle adjustment;
// shared blocks are not (their elimination would couple every vertex).
template <int D>
GlobalSolveSummary GlobalProblem<D>::solve(const GlobalSolverOptions& options,
                                           const std::function<bool(int)>& on_iteration) {
  ceres::Solver::Options o;
  if (options.linear_solver == LinearSolver::kSparseNormalCholesky) {
    o.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  } else if (options.linear_solver == LinearSolver::kSparseSchur || options.linear_solver == LinearSolver::kIterativeSchur) {
    o.linear_solver_type = options.linear_solver == LinearSolver::kSparseSchur ? ceres::SPARSE_SCHUR : ceres::ITERATIVE_SCHUR;
    o.preconditioner_type = ceres::SCHUR_JACOBI;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    bool any_eliminated = false;
    for (size_t b = 0; b < impl_->auxiliary.size(); ++b) {
      ordering->AddElementToGroup(impl_->auxiliary[b].data(), impl_->eliminated[b] ? 0 : 1);
      any_eliminated = any_eliminated || impl_->eliminated[b];
    }
    for (int v = 0; v < impl_->num_vertices; ++v) ordering->AddElementToGroup(vertex(v), 1);
    if (any_eliminated) o.linear_solver_ordering = ordering;  // else Ceres picks its own
  } else if (options.linear_solver == LinearSolver::kCgnr) {
    o.linear_solver_type = ceres::CGNR;
    o.preconditioner_type = ceres::JACOBI;
  } else if (options.linear_solver == LinearSolver::kDenseQr) {
    o.linear_solver_type = ceres::DENSE_QR;
  } else {
    DSNAKE_ASSERT(false, "unknown linear solver");
  }
  o.max_num_iterations = options.max_iterations;
  o.max_solver_time_in_seconds = options.max_time_s;
  o.initial_trust_region_radius = options.initial_trust_region_radius;
  o.max_trust_region_radius = options.max_trust_region_radius;
  o.function_tolerance = options.function_tolerance;
  o.gradient_tolerance = options.gradient_tolerance;
  o.parameter_tolerance = options.parameter_tolerance;
  o.num_threads = std::max(1, options.threads);
  o.logging_type = ceres::SILENT;
  o.minimizer_progress_to_stdout = false;
  std::unique_ptr<ForwardingCallback> callback;
  if (on_iteration) {
    callback = std::make_unique<ForwardingCallback>(on_iteration);
    o.update_state_every_iteration = true;
    o.callbacks.push_back(callback.get());
  }
  ceres::Solver::Summary summary;
  ceres::Solve(o, &impl_->problem, &summary);
  GlobalSolveSummary s;
  s.successful_steps = summary.num_successful_steps;
  s.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  s.residual_evaluations = summary.num_residual_evaluations;
  s.jacobian_evaluations = summary.num_jacobian_evaluations;
  s.initial_cost = 2.0 * summary.initial_cost;
  s.final_cost = 2.0 * summary.final_cost;
  s.termination = termination_name(summary.termination_type);
  s.message = summary.message;
  s.time_s = summary.total_time_in_seconds;
  s.usable = summary.IsSolutionUsable();
  return s;
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
