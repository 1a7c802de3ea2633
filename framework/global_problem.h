// GlobalProblem<D>: the global view of the energies, one non-linear least-squares problem over
// all vertex positions (Ceres Solver behind a pimpl; only this header's users that add custom
// cost functions include Ceres themselves). Energies add residual blocks r_k with
// E_e(q) = sum_k |r_k(q)|^2 (energy.h); the total E = sum_e w_e E_e is then
// sum_of_squares(), which is twice Ceres' cost (Ceres minimises 1/2 sum |r|^2).
// The Ceres solve that uses it comes with the global-solve baseline.
#pragma once

#include "framework/shape.h"

#include <memory>
#include <span>
#include <vector>

namespace ceres {
class CostFunction;
class Problem;
}  // namespace ceres

namespace dsnake {

template <int D>
class GlobalProblem {
 public:
  // One parameter block of D doubles per snake vertex, initialised to the snake's positions.
  explicit GlobalProblem(const Snake<D>& snake);
  ~GlobalProblem();
  GlobalProblem(const GlobalProblem&) = delete;
  GlobalProblem& operator=(const GlobalProblem&) = delete;

  // Adds the D residuals r = scale * sum_k coefficients[k] * q[vertices[k]] (a linear form of
  // the positions, as the internal, Laplacian and difference energies use).
  void add_linear_residual(std::span<const int> vertices, std::span<const double> coefficients, double scale);
  // Adds a Ceres cost function whose parameter blocks are the listed vertices' positions
  // (D doubles each); the problem takes ownership of `cost`.
  void add_residual_block(ceres::CostFunction* cost, const std::vector<int>& vertices);

  int num_vertices() const;
  int num_residual_blocks() const;
  double* vertex(int v);                 // the parameter block of vertex v
  PointList<D> positions() const;        // the current parameter values
  double sum_of_squares() const;         // sum_k |r_k|^2 at the current parameters
  ceres::Problem& problem();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dsnake
