// The classical snake internal energy: tension (alpha) and rigidity (beta), moved by the
// semi-implicit step of Kass, Witkin and Terzopoulos, "Snakes: Active contour models" (IJCV
// 1988), appendix eqs. (19)-(20), with the internal force alone: q' = (gamma I + A)^{-1} gamma q.
// This is q^int of the paper's snake update (Levi & Gotsman, D-Snake, §3.1).
//  - 2D (closed polygon, vertex order = polygon order): A is Kass's cyclic pentadiagonal matrix,
//    rows (beta, -alpha-4beta, 2alpha+6beta, -alpha-4beta, beta).
//  - 3D (closed triangle mesh): A = alpha L + beta L^2 with the umbrella Laplacian
//    (L q)_i = q_i - mean of the one-ring of i.
// The factorisation is built in bind() and kept until the snake's topology changes.
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <cstdint>
#include <memory>
#include <string>

namespace dsnake {

// How (gamma I + A) x = gamma q is solved:
//  - kDirect ("direct"): sparse LDL^T, factorised once per topology (exact to rounding);
//  - kChebyshev ("chebyshev"): Chebyshev semi-iteration from x0 = q over the known spectrum of
//    gamma I + A ([gamma, gamma + 2 alpha + 4 beta] on a mesh, [gamma, gamma + 4 alpha + 16 beta]
//    on a polygon), with the iteration count fixed in advance so that every vertex's error is at
//    most `tolerance` times the step's largest displacement; no factorisation, no reductions (the
//    result does not depend on the thread count), one or two one-ring passes per iteration;
//  - kAuto ("auto", default): chebyshev on meshes when that needs <= 32 iterations (a
//    well-conditioned step: (2 alpha + 4 beta) / gamma <= ~11), direct otherwise and on polygons.
enum class InternalSolver { kAuto, kDirect, kChebyshev };
template <>
struct EnumNames<InternalSolver> {
  static constexpr std::array<std::pair<InternalSolver, const char*>, 3> table{
      {{InternalSolver::kAuto, "auto"}, {InternalSolver::kDirect, "direct"}, {InternalSolver::kChebyshev, "chebyshev"}}};
};

struct InternalOptions {
  double alpha = 0.5;  // tension: weight of the first differences
  double beta = 0.0;   // rigidity: weight of the second differences
  double gamma = 1.0;  // Kass's step viscosity (inverse step size)
  InternalSolver solver = InternalSolver::kAuto;
  double tolerance = 1e-10;  // chebyshev: error bound relative to the largest displacement

  template <class V>
  void visit(V& v) {
    v(alpha, Key{"alpha", "1 (per vertex, umbrella form)", "tension: weight of the first differences", Range::at_least(0)});
    v(beta, Key{"beta", "1 (per vertex, umbrella form)", "rigidity: weight of the second differences", Range::at_least(0)});
    v(gamma, Key{"gamma", "1", "Kass's step viscosity (inverse step size)", Range::greater_than(0)});
    v(solver, Key{"solver", "", "how (gamma I + A) x = gamma q is solved"});
    v(tolerance, Key{"tolerance", "1 (relative)", "chebyshev: error bound relative to the step's largest displacement", Range::open(0, 1)});
  }
};

template <int D>
class InternalEnergy final : public Energy<D> {
 public:
  using Options = InternalOptions;
  static constexpr const char* kType = "internal";
  static constexpr const char* kSummary = "Kass's tension and rigidity, semi-implicit step (q^int of §3.1)";

  explicit InternalEnergy(const InternalOptions& options = {});
  ~InternalEnergy() override;

  std::string type() const override { return kType; }
  const InternalOptions& options() const { return options_; }

  // Builds and factorises gamma I + A for the snake's connectivity (always rebuilds); with the
  // Chebyshev solver, builds the one-ring table and the iteration count instead.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;

  // out[v] = ((gamma I + A)^{-1} gamma q)_v for every vertex. Asserts that bind() saw the
  // snake's current topology (the phase driver rebinds after a remesh). Allocates nothing.
  void propose(const Snake<D>& snake, PointList<D>& out) override;

  // 2D: sum_i 1/2 alpha |q_{i+1} - q_i|^2 + 1/2 beta |q_{i+1} - 2 q_i + q_{i-1}|^2, whose
  //     gradient is exactly A q.
  // 3D: sum_edges 1/2 alpha |q_i - q_j|^2 + sum_v 1/2 beta |(L q)_v|^2 with the umbrella L.
  //     The alpha term's gradient is the combinatorial Laplacian (degree minus adjacency), while
  //     the step uses the umbrella operator (its degree-normalised form): the snake scheme of
  //     §3.1 uses the step; this value is for energy traces and the global solve.
  double value(const Snake<D>& snake) const override;
  // Chebyshev iterations per step for the bound snake; 0 when the direct solve is used.
  int chebyshev_iterations() const;
  // The residuals of value(): sqrt(w alpha / 2) (q_j - q_i) per edge, and sqrt(w beta / 2) times
  // the second difference (2D) or the umbrella Laplacian (3D) per vertex.
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

 private:
  struct Solver;  // the sparse factorisation and scratch, in the .cpp

  void propose_direct(const Snake<D>& snake, PointList<D>& out);
  void propose_chebyshev(const Snake<D>& snake, PointList<D>& out);

  InternalOptions options_;
  std::unique_ptr<Solver> solver_;
};

}  // namespace dsnake
