// The classical snake internal energy E_int = int 1/2 (alpha |X'|^2 + beta |X''|^2) ds (Levi &
// Gotsman, D-Snake, §1; Kass, Witkin and Terzopoulos, "Snakes: Active contour models", IJCV 1988),
// moved by a semi-implicit step with the internal force alone: q^int of the paper's snake update
// (§3.1). Two discretisations ("discretization"):
//  - kPhysical ("physical", default): s is arc length (2D) or surface area (3D), so that the same
//    alpha, beta, gamma give the same continuous flow gamma X_t = alpha X_ss - beta X_ssss at every
//    resolution. The step is that of implicit fairing (Desbrun, Meyer, Schroeder and Barr,
//    "Implicit fairing of irregular meshes using diffusion and curvature flow", SIGGRAPH 1999):
//      (gamma M + alpha K + beta K M^-1 K) x = gamma M q,
//    M the lumped mass and K the stiffness of piecewise-linear elements at the current positions
//    (framework/operators/mesh_operators.h):
//      2D: M_i = half the two adjacent edge lengths, K_ij = -1 / l_ij for the edges, K_ii = sum_j 1 / l_ij;
//      3D: M_i = the mixed Voronoi area of i (Meyer, Desbrun, Schroeder and Barr 2003: Voronoi
//          parts in non-obtuse triangles, A/2 at an obtuse angle and A/4 at the others; on
//          icospheres of radius 10 mm every vertex's radial move is within 0.03% of the sphere's
//          flow, where one third of the adjacent areas is 10% off at the valence-5 vertices of the
//          162-vertex one), K the cotangent Laplacian, K_ij = -1/2 (cot a_ij + cot b_ij), written
//          per triangle as K_T,ij = e_i . e_j / (4 A_T) (e_i the edge opposite vertex i).
//    On a circle (sphere) of radius R mm one step moves a vertex inward by R a / (gamma + a) with
//    a = alpha / R^2 + beta / R^4 (2D; exact on a regular polygon) or a = 2 alpha / R^2 + 4 beta / R^4
//    (3D, mean curvature H = 1/R), about alpha / (gamma R) mm (2 alpha / (gamma R) on a sphere):
//    alpha is in mm^2 and beta in mm^4 per unit of gamma (1 per step). Scaling a shape by s scales
//    its step by s as the step with alpha / s^2, beta / s^4 would (K is scale-free in 3D).
//    Refresh: M and K are recomputed from the snake's positions at every propose(); the system's
//    pattern, its fill-reducing (AMD) ordering and the symbolic factorisation are kept per
//    topology, the numeric LDL^T is redone every step (serial: the same bits on any thread count).
//    With beta > 0 the step is solved in the mixed form [gamma M + alpha K, K; K, -M / beta]
//    [x; y] = [gamma M q; 0] (y = beta M^-1 K x; symmetric quasi-definite), whose one-ring
//    pattern factorises several times faster than the two-ring K M^-1 K.
//    Degenerate elements: an edge length is floored at 1e-3 times the mean edge length, a triangle
//    area at 1e-3 times the mean squared edge length (1 mm / 1 mm^2 when every edge has zero
//    length), in both M and K, and so is every vertex mass. A floored triangle's K_T is its true
//    K_T times A_T / A_floor, still positive semi-definite (clamping each cotangent alone would
//    not be), with entries at most l_max^2 / (4 A_floor): no NaN or Inf from a zero-length edge
//    or a zero-area triangle.
//  - kUmbrella ("umbrella"): per vertex with unit parameter steps, as in Kass's appendix and the
//    paper's MATLAB-style snakes (alpha, beta dimensionless; the force grows with the square of
//    the edge length, so the same alpha is much stronger on a coarse shape):
//    q' = (gamma I + A)^{-1} gamma q,
//      2D (vertex order = polygon order): A is Kass's cyclic pentadiagonal matrix, eqs. (19)-(20),
//         rows (beta, -alpha-4beta, 2alpha+6beta, -alpha-4beta, beta);
//      3D: A = alpha L + beta L^2 with the umbrella Laplacian (L q)_i = q_i - mean of the one-ring of i;
//    factorised in bind() and kept until the snake's topology changes.
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <cstdint>
#include <memory>
#include <string>

namespace dsnake {

// How the umbrella form's (gamma I + A) x = gamma q is solved (the physical form always solves directly):
//  - kDirect ("direct"): sparse LDL^T, factorised once per topology (exact to rounding);
//  - kChebyshev ("chebyshev"): Chebyshev semi-iteration from x0 = q over the known spectrum of
//    gamma I + A ([gamma, gamma + 2 alpha + 4 beta] on a mesh, [gamma, gamma + 4 alpha + 16 beta]
//    on a polygon), with the iteration count fixed in advance so that every vertex's error is at
//    most `tolerance` times the step's largest displacement; no factorisation, no reductions (the
//    result does not depend on the thread count), one or two one-ring passes per iteration;
//  - kAuto ("auto", default): umbrella: chebyshev on meshes when that needs <= 32 iterations (a
//    well-conditioned step: (2 alpha + 4 beta) / gamma <= ~11), direct otherwise and on polygons;
//    physical: with beta = 0, conjugate gradients preconditioned by the diagonal, from x0 = q, until
//    the residual is `tolerance` times the internal force (serial: thread-count independent; falls
//    back to the direct solve if 500 iterations do not get there); with beta > 0, direct (the
//    spectrum of M^-1 K depends on the geometry, with no safe a-priori bound for Chebyshev).
//    "direct" forces the numeric refactorisation every step. With alpha = beta = 0 the step is q.
// "chebyshev" with "physical" is refused (check()).
enum class InternalSolver { kAuto, kDirect, kChebyshev };
template <>
struct EnumNames<InternalSolver> {
  static constexpr std::array<std::pair<InternalSolver, const char*>, 3> table{
      {{InternalSolver::kAuto, "auto"}, {InternalSolver::kDirect, "direct"}, {InternalSolver::kChebyshev, "chebyshev"}}};
};

// How E_int is discretised (see the file comment).
enum class InternalDiscretization { kPhysical, kUmbrella };
template <>
struct EnumNames<InternalDiscretization> {
  static constexpr std::array<std::pair<InternalDiscretization, const char*>, 2> table{
      {{InternalDiscretization::kPhysical, "physical"}, {InternalDiscretization::kUmbrella, "umbrella"}}};
};

struct InternalOptions {
  // physical: mm^2 per unit gamma (one step moves a circle of radius R mm in by ~ alpha / (gamma R) mm,
  // a sphere by ~ 2 alpha / (gamma R)); umbrella: per vertex, dimensionless.
  double alpha = 0.5;  // tension: weight of |X'|^2
  double beta = 0.0;   // rigidity: weight of the squared second derivative X''(s); physical: mm^4 per unit gamma
  double gamma = 1.0;  // Kass's step viscosity (inverse step size), 1 per step
  InternalSolver solver = InternalSolver::kAuto;
  double tolerance = 1e-10;  // chebyshev / physical CG: error bound relative to the step (see InternalSolver)
  InternalDiscretization discretization = InternalDiscretization::kPhysical;

  template <class V>
  void visit(V& v) {
    v(discretization, Key{"discretization", "", "physical: by arc length / area, the same flow at every resolution; umbrella: per vertex with unit steps (Kass's matrix, the paper's MATLAB-style snakes)"});
    v(alpha, Key{"alpha", "mm^2 per unit gamma (physical); 1 per vertex (umbrella)", "tension: weight of the squared first derivative X'(s); physical: one step moves a circle of radius R mm in by ~ alpha / (gamma R) mm, a sphere by ~ 2 alpha / (gamma R) mm (a small step: alpha << gamma R^2)", Range::at_least(0)});
    v(beta, Key{"beta", "mm^4 per unit gamma (physical); 1 per vertex (umbrella)", "rigidity: weight of the squared second derivative X''(s); physical: one step moves a circle of radius R mm in by ~ beta / (gamma R^3) mm, a sphere by ~ 4 beta / (gamma R^3) mm", Range::at_least(0)});
    v(gamma, Key{"gamma", "1 (per step)", "Kass's step viscosity (inverse step size)", Range::greater_than(0)});
    v(solver, Key{"solver", "", "how the step's linear system is solved (physical, auto: conjugate gradients with beta 0, direct otherwise)"});
    v(tolerance, Key{"tolerance", "1 (relative)", "umbrella chebyshev: error bound relative to the step's largest displacement; physical conjugate gradients (beta 0): residual relative to the internal force", Range::open(0, 1)});
  }
  void check() const {
    if (discretization == InternalDiscretization::kPhysical && solver == InternalSolver::kChebyshev)
      throw OptionError{"solver", "chebyshev needs \"discretization\": \"umbrella\" (the physical step's spectrum depends on the geometry); use \"direct\" or \"auto\""};
  }
};

template <int D>
class InternalEnergy final : public Energy<D> {
 public:
  using Options = InternalOptions;
  static constexpr const char* kType = "internal";
  static constexpr const char* kSummary =
      "Kass's tension and rigidity by arc length / area (or per vertex), semi-implicit step (q^int of §3.1)";

  explicit InternalEnergy(const InternalOptions& options = {});
  ~InternalEnergy() override;

  std::string type() const override { return kType; }
  const InternalOptions& options() const { return options_; }

  // Umbrella: builds and factorises gamma I + A for the snake's connectivity (always rebuilds);
  // with the Chebyshev solver, builds the one-ring table and the iteration count instead.
  // Physical: builds the system's pattern, ordering and symbolic factorisation.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;

  // out[v] = ((gamma I + A)^{-1} gamma q)_v (umbrella) or ((gamma M + alpha K + beta K M^-1 K)^-1
  // gamma M q)_v with M, K at the current positions (physical) for every vertex. Asserts that
  // bind() saw the snake's current topology (the phase driver rebinds after a remesh). Allocates
  // nothing but, in the physical form, Eigen's scratch of the numeric refactorisation.
  void propose(const Snake<D>& snake, PointList<D>& out) override;

  // Physical, with M and K at the current positions (so E is not quadratic in q):
  //   1/2 alpha q^T K q + 1/2 beta sum_i M_i |(M^-1 K q)_i|^2, i.e.
  //   2D: 1/2 alpha sum_edges |q_j - q_i|^2 / l_ij + ..., 3D: the cotangent Dirichlet energy + ...
  //   (at its own positions the alpha term is alpha / 2 times the length, alpha times the area).
  // Umbrella:
  // 2D: sum_i 1/2 alpha |q_{i+1} - q_i|^2 + 1/2 beta |q_{i+1} - 2 q_i + q_{i-1}|^2, whose
  //     gradient is exactly A q.
  // 3D: sum_edges 1/2 alpha |q_i - q_j|^2 + sum_v 1/2 beta |(L q)_v|^2 with the umbrella L.
  //     The alpha term's gradient is the combinatorial Laplacian (degree minus adjacency), while
  //     the step uses the umbrella operator (its degree-normalised form): the snake scheme of
  //     §3.1 uses the step; this value is for energy traces and the global solve.
  double value(const Snake<D>& snake) const override;
  // Chebyshev iterations per step for the bound snake; 0 when the direct solve is used.
  int chebyshev_iterations() const;
  // Conjugate-gradient iterations of the last physical step with beta = 0; 0 when it was solved
  // directly (or is the identity, alpha = beta = 0).
  int conjugate_gradient_iterations() const;
  // The residuals of value() (their squares sum to it at the positions of the call).
  // Physical: linear residuals with M and K frozen at the snake's positions when called, so that
  //   their gradient is the step's (alpha K + beta K M^-1 K) q: 2D sqrt(w alpha / (2 l_ij)) (q_j - q_i)
  //   per edge; 3D per triangle the in-plane gradient sqrt(w alpha A_T / 2) grad X_T (two residuals
  //   of D, positive semi-definite even where cotangents are negative); per vertex
  //   sqrt(w beta M_i / 2) (M^-1 K q)_i.
  // Umbrella: sqrt(w alpha / 2) (q_j - q_i) per edge, and sqrt(w beta / 2) times the second
  //   difference (2D) or the umbrella Laplacian (3D) per vertex.
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

 private:
  struct Solver;  // the sparse factorisation and scratch, in the .cpp

  void bind_umbrella(const Snake<D>& snake);
  void bind_physical(const Snake<D>& snake);
  void propose_direct(const Snake<D>& snake, PointList<D>& out);
  void propose_physical(const Snake<D>& snake, PointList<D>& out);
  void propose_chebyshev(const Snake<D>& snake, PointList<D>& out);
  double physical_value(const Snake<D>& snake) const;
  void add_physical_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const;

  InternalOptions options_;
  std::unique_ptr<Solver> solver_;
};

}  // namespace dsnake
