// GlobalProblem<D>: the global view of the energies, one non-linear least-squares problem over
// all vertex positions (Ceres Solver behind a pimpl; only this header's users that add custom
// cost functions include Ceres themselves). Energies add residual blocks r_k with
// E_e(q) = sum_k |r_k(q)|^2 (energy.h); the total E = sum_e w_e E_e is then
// sum_of_squares(), which is twice Ceres' cost (Ceres minimises 1/2 sum |r|^2).
// Besides the vertex positions, an energy may add auxiliary parameter blocks (ASAP's per-vertex
// similarity, ARAP's per-vertex rotation): they are the first group of the Schur ordering, since
// no residual couples two of them. A shared block (the region term's two means, which every one
// of its residuals touches) stays with the vertices: eliminating it first would fill the reduced
// system.
#pragma once

#include "framework/core/options.h"
#include "framework/core/shape.h"

#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace ceres {
class CostFunction;
class Problem;
}  // namespace ceres

namespace dsnake {

// The auxiliary blocks' parameterisations. A rotation in 2D is an angle (Euclidean); a rotation
// in 3D is a unit quaternion [w, x, y, z] on Ceres' quaternion manifold; a similarity appends
// the log-scale: [angle, log s] in 2D, [w, x, y, z, log s] in 3D (quaternion x Euclidean).
// kSharedEuclidean: Euclidean, shared by residuals of many vertices (not eliminated first).
enum class AuxiliaryKind { kEuclidean, kQuaternion, kQuaternionAndScale, kSharedEuclidean };

// Ceres solver options (the experiment file's "global" object; see experiments/spec/experiment_spec.cpp).
// Ceres' linear solver: sparse_normal_cholesky; sparse_schur (eliminates the auxiliary blocks);
// the matrix-free cgnr and iterative_schur (conjugate gradients); dense_qr (tiny problems).
enum class LinearSolver { kSparseNormalCholesky, kSparseSchur, kIterativeSchur, kCgnr, kDenseQr };
template <>
struct EnumNames<LinearSolver> {
  static constexpr std::array<std::pair<LinearSolver, const char*>, 5> table{
      {{LinearSolver::kSparseNormalCholesky, "sparse_normal_cholesky"}, {LinearSolver::kSparseSchur, "sparse_schur"},
       {LinearSolver::kIterativeSchur, "iterative_schur"}, {LinearSolver::kCgnr, "cgnr"}, {LinearSolver::kDenseQr, "dense_qr"}}};
};

struct GlobalSolverOptions {
  LinearSolver linear_solver = LinearSolver::kSparseNormalCholesky;
  int max_iterations = 200;
  // Levenberg-Marquardt's trust region (in the scaled step norm): a small radius keeps the solve
  // local, near the start, as the snake is; Ceres' defaults (1e4, 1e16) let its first
  // Gauss-Newton step jump to the membrane energy's collapsed minimum (measured: Dice 0).
  double initial_trust_region_radius = 1.0;
  double max_trust_region_radius = 10.0;
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;
  double parameter_tolerance = 1e-10;
  int threads = 1;  // Ceres' threads (part of the file, so the numbers do not depend on --threads)
  int remesh_rounds = 2;  // a phase with remeshers: solve, then (remesh, re-solve) this many times
  // Wall-clock bound on the whole global solve (every phase and remesh round), checked by Ceres
  // after each iteration (max_solver_time_in_seconds); reaching it stops the run as diverged.
  double max_time_s = 600;

  template <class V>
  void visit(V& v) {
    v(linear_solver, Key{"linear_solver", "", "Ceres' linear solver"});
    v(max_iterations, Key{"max_iterations", "iterations", "Levenberg-Marquardt iterations per solve", Range::closed(1, 1000000)});
    v(initial_trust_region_radius, Key{"initial_trust_region_radius", "1 (scaled step)", "first trust region radius; small keeps the solve near the start", Range::greater_than(0)});
    v(max_trust_region_radius, Key{"max_trust_region_radius", "1 (scaled step)", "largest trust region radius (>= initial_trust_region_radius)", Range::greater_than(0)});
    v(function_tolerance, Key{"function_tolerance", "1 (relative)", "Ceres' relative cost change to stop at", Range::at_least(0)});
    v(gradient_tolerance, Key{"gradient_tolerance", "1 (relative)", "Ceres' gradient tolerance", Range::at_least(0)});
    v(parameter_tolerance, Key{"parameter_tolerance", "1 (relative)", "Ceres' relative step size to stop at", Range::at_least(0)});
    v(threads, Key{"threads", "threads", "Ceres' threads (in the file so that the numbers do not depend on --threads)", Range::closed(1, 256)});
    v(remesh_rounds, Key{"remesh_rounds", "rounds", "a phase with remeshers: solve, then (remesh, re-solve) this many times", Range::closed(0, 1000)});
    v(max_time_s, Key{"max_time_s", "s",
                      "wall-clock bound on the whole global solve (all phases and remesh rounds), checked after each "
                      "Ceres iteration; reaching it stops the run as diverged (exit code 3) with the last iteration's positions",
                      Range::open_closed(0, 1e7)});
  }
  void check() const {
    if (max_trust_region_radius < initial_trust_region_radius)
      throw OptionError{"max_trust_region_radius", "must be >= initial_trust_region_radius"};
  }
};

// What Ceres reports (its Summary), for result.json.
struct GlobalSolveSummary {
  int iterations = 0;  // successful + unsuccessful steps
  int successful_steps = 0;
  int residual_evaluations = 0, jacobian_evaluations = 0;
  double initial_cost = 0, final_cost = 0;  // sum_k |r_k|^2 (twice Ceres' own cost)
  std::string termination;                  // "convergence", "no_convergence", "failure"
  std::string message;
  double time_s = 0;
  bool usable = false;
};

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
  // Adds an auxiliary parameter block initialised to `initial`; returns its index.
  int add_auxiliary_block(std::span<const double> initial, AuxiliaryKind kind);
  // Adds a cost function whose parameter blocks are the listed auxiliary blocks, then the
  // listed vertices' positions.
  void add_residual_block(ceres::CostFunction* cost, const std::vector<int>& auxiliary, const std::vector<int>& vertices);

  int num_vertices() const;
  int num_residual_blocks() const;
  double* vertex(int v);                 // the parameter block of vertex v
  PointList<D> positions() const;        // the current parameter values
  double sum_of_squares() const;         // sum_k |r_k|^2 at the current parameters
  int num_auxiliary_blocks() const;
  double* auxiliary(int b);              // the parameter block of auxiliary block b
  ceres::Problem& problem();

  // Minimises sum_k |r_k|^2 over all parameter blocks with Ceres' trust-region solver.
  // `on_iteration(i)` is called after every iteration with the current positions in place
  // (positions()); returning false stops the solve.
  GlobalSolveSummary solve(const GlobalSolverOptions& options,
                           const std::function<bool(int iteration)>& on_iteration = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dsnake
