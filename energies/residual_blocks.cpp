// Ceres cost functions for the deformation energies; see residual_blocks.h.
#include "energies/residual_blocks.h"

#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
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

// r = c (S a - (q_other - q_centre)) in 2D with S = e^sigma R(theta): parameters [theta(, sigma)].
template <bool kScale>
struct Transform2dResidual {
  double ax, ay, c;
  template <typename T>
  bool operator()(const T* s, const T* centre, const T* other, T* r) const {
    using std::cos, std::exp, std::sin;
    const T mu = kScale ? exp(s[1]) : T(1.0);
    const T co = mu * cos(s[0]), si = mu * sin(s[0]);
    r[0] = c * (co * ax - si * ay - (other[0] - centre[0]));
    r[1] = c * (si * ax + co * ay - (other[1] - centre[1]));
    return true;
  }
};

// The same in 3D with S = e^sigma R(quaternion [w, x, y, z]): parameters [w, x, y, z(, sigma)].
template <bool kScale>
struct Transform3dResidual {
  double a[3], c;
  template <typename T>
  bool operator()(const T* s, const T* centre, const T* other, T* r) const {
    using std::exp;
    const T p[3] = {T(a[0]), T(a[1]), T(a[2])};
    T rotated[3];
    ceres::QuaternionRotatePoint(s, p, rotated);
    const T mu = kScale ? exp(s[4]) : T(1.0);
    for (int k = 0; k < 3; ++k) r[k] = c * (mu * rotated[k] - (other[k] - centre[k]));
    return true;
  }
};

// r = sqrt(w (P(q) + eps)), dr/dq = w grad P / (2 r).
template <int D>
class PotentialCost : public ceres::SizedCostFunction<1, D> {
 public:
  PotentialCost(const Potential<D>& potential, double weight) : potential_(potential), weight_(weight) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Point<D> gradient;
    const Point<D> x = Eigen::Map<const Point<D>>(parameters[0]);
    const double p = potential_.value_and_gradient(x, gradient);
    if (!std::isfinite(p)) return false;
    const double r = std::sqrt(weight_ * (std::max(p, 0.0) + 1e-12));
    residuals[0] = r;
    if (jacobians && jacobians[0])
      for (int a = 0; a < D; ++a) jacobians[0][a] = weight_ * gradient[a] / (2.0 * r);
    return true;
  }

 private:
  const Potential<D>& potential_;
  double weight_;
};

// r = scale (q - target), dr/dq = scale I.
template <int D>
class AnchorCost : public ceres::SizedCostFunction<D, D> {
 public:
  AnchorCost(const Point<D>& target, double scale) : target_(target), scale_(scale) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    for (int a = 0; a < D; ++a) residuals[a] = scale_ * (parameters[0][a] - target_[a]);
    if (jacobians && jacobians[0])
      for (int a = 0; a < D; ++a)
        for (int b = 0; b < D; ++b) jacobians[0][a * D + b] = a == b ? scale_ : 0.0;
    return true;
  }

 private:
  Point<D> target_;
  double scale_;
};

}  // namespace

template <int D>
void add_anchor_residual(GlobalProblem<D>& problem, int v, const Point<D>& target, double scale) {
  problem.add_residual_block(new AnchorCost<D>(target, scale), {v});
}

template <int D>
void add_block_linear_residual(GlobalProblem<D>& problem, const std::vector<int>& vertices,
                               const std::vector<Block<D>>& blocks, double scale) {
  DSNAKE_ASSERT(vertices.size() == blocks.size() && !vertices.empty(), "one block per vertex");
  problem.add_residual_block(new BlockLinearCost<D>(blocks, scale), vertices);
}

template <int D>
void add_transform_residuals(GlobalProblem<D>& problem, int centre, const std::vector<int>& others,
                             const PointList<D>& a, const std::vector<double>& scales, bool with_scale,
                             const Block<D>& initial) {
  DSNAKE_ASSERT(others.size() == a.size() && a.size() == scales.size(), "one offset and scale per neighbour");
  // Split the initial transform into mu and a rotation (mu = 1, R = I where it is degenerate).
  double mu = std::sqrt(std::max(0.0, (initial.transpose() * initial).trace() / D));
  Block<D> rotation = mu > 1e-12 ? Block<D>(initial / mu) : Block<D>::Identity();
  if (!(mu > 1e-12)) mu = 1.0;
  std::vector<double> initial_block;
  if constexpr (D == 2) {
    initial_block.push_back(std::atan2(rotation(1, 0), rotation(0, 0)));
  } else {
    const Eigen::Quaterniond q(rotation);
    initial_block = {q.w(), q.x(), q.y(), q.z()};
  }
  if (with_scale) initial_block.push_back(std::log(mu));
  const AuxiliaryKind kind = D == 2 ? AuxiliaryKind::kEuclidean
                                    : with_scale ? AuxiliaryKind::kQuaternionAndScale : AuxiliaryKind::kQuaternion;
  const int block = problem.add_auxiliary_block(initial_block, kind);
  for (size_t k = 0; k < others.size(); ++k) {
    ceres::CostFunction* cost = nullptr;
    if constexpr (D == 2) {
      if (with_scale)
        cost = new ceres::AutoDiffCostFunction<Transform2dResidual<true>, 2, 2, 2, 2>(
            new Transform2dResidual<true>{a[k][0], a[k][1], scales[k]});
      else
        cost = new ceres::AutoDiffCostFunction<Transform2dResidual<false>, 2, 1, 2, 2>(
            new Transform2dResidual<false>{a[k][0], a[k][1], scales[k]});
    } else {
      if (with_scale)
        cost = new ceres::AutoDiffCostFunction<Transform3dResidual<true>, 3, 5, 3, 3>(
            new Transform3dResidual<true>{{a[k][0], a[k][1], a[k][2]}, scales[k]});
      else
        cost = new ceres::AutoDiffCostFunction<Transform3dResidual<false>, 3, 4, 3, 3>(
            new Transform3dResidual<false>{{a[k][0], a[k][1], a[k][2]}, scales[k]});
    }
    problem.add_residual_block(cost, {block}, {centre, others[k]});
  }
}

template <int D>
void add_potential_residual(GlobalProblem<D>& problem, int v, const Potential<D>& potential, double weight) {
  problem.add_residual_block(new PotentialCost<D>(potential, weight), std::vector<int>{v});
}

template void add_anchor_residual<2>(GlobalProblem<2>&, int, const Point<2>&, double);
template void add_anchor_residual<3>(GlobalProblem<3>&, int, const Point<3>&, double);
template void add_potential_residual<2>(GlobalProblem<2>&, int, const Potential<2>&, double);
template void add_potential_residual<3>(GlobalProblem<3>&, int, const Potential<3>&, double);
template void add_block_linear_residual<2>(GlobalProblem<2>&, const std::vector<int>&, const std::vector<Block<2>>&, double);
template void add_block_linear_residual<3>(GlobalProblem<3>&, const std::vector<int>&, const std::vector<Block<3>>&, double);
template void add_transform_residuals<2>(GlobalProblem<2>&, int, const std::vector<int>&, const PointList<2>&,
                                        const std::vector<double>&, bool, const Block<2>&);
template void add_transform_residuals<3>(GlobalProblem<3>&, int, const std::vector<int>&, const PointList<3>&,
                                        const std::vector<double>&, bool, const Block<3>&);

}  // namespace dsnake
