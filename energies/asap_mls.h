// The ASAP-MLS deformation energy of Levi & Gotsman, D-Snake (IEEE TVCG), §4:
//   E_def(q) = sum_j D_j(q),  D_j(q) = min_{T_j similarity, T_j(p_j) = q_j} sum_{i in N(j)} w_ij |T_j(p_i) - q_i|^2,
// with the weights of eq. (2) over a neighbourhood N(j) of template vertex j (mls_weights.h). The
// constraint T_j(p_j) = q_j is the infinite weight w_jj of eq. (2) (§4.1: q_j* = q_j).
// Snake view (propose), by `variant`:
//  - "exact", 2D (§4.1): E_def is a quadratic form q^T H q; one step applies A (Jacobi, eq. (5)) or
//    A2 (Gauss-Seidel), `power` m times (A3), damped by `damping` lambda (A4 = (1-l) I + l A2).
//  - "exact", 3D (§4.2): alternately the optimal mu_j R_j of every D_j, then every vertex moved
//    to its minimiser with the others frozen.
//  - "approximate" (§4.3 eq. (6), §4.4): q_j <- T^_j(p_j), T^_j the weighted similarity fit of
//    the neighbours (without j) (Appendix: 3x3 SVD in 3D, reflection-safe); `iteration`
//    "gauss_seidel" updates one vertex at a time from the newest positions (serial), "jacobi"
//    all from the old ones (parallel).
//  - `net_motion`: the rigid (or similarity) part of the move q' - q, which the energy's gradient
//    never has, can be removed; by default it is for the approximate variant (see AsapNetMotion).
// ASAP governs the template ("deformation") vertices only (§6); everything per template vertex
// is precomputed once per template (§7), and a remesh only rebuilds the id -> vertex map.
// The rest shape p is the template's (the paper's), or with `rest` "phase_start" the template
// vertices' positions at the start of each phase (ours): a later phase then keeps locally as
// similar as possible to what the previous phase found, and where its forces have no evidence
// (a patch that correlates too little, and holds) the shape stays as the previous phase left
// it instead of relaxing back towards the template's.
#pragma once

#include "energies/mls_weights.h"
#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <memory>
#include <string>

namespace dsnake {

enum class AsapVariant { kExact, kApproximate };
template <>
struct EnumNames<AsapVariant> {
  static constexpr std::array<std::pair<AsapVariant, const char*>, 2> table{
      {{AsapVariant::kExact, "exact"}, {AsapVariant::kApproximate, "approximate"}}};
};
// exact 2D and approximate: kJacobi (A) or kGaussSeidel (A2); exact 3D: kJacobi only (§4.2 moves
// every vertex with the others frozen). kAuto: Gauss-Seidel where there is a choice.
enum class AsapIteration { kAuto, kJacobi, kGaussSeidel };
template <>
struct EnumNames<AsapIteration> {
  static constexpr std::array<std::pair<AsapIteration, const char*>, 3> table{
      {{AsapIteration::kAuto, "auto"}, {AsapIteration::kJacobi, "jacobi"}, {AsapIteration::kGaussSeidel, "gauss_seidel"}}};
};

// What becomes of the net similarity motion of a proposal (q' - q: its least-squares components
// along the translations, the rotations about the centroid and the scaling of q, unit masses on
// the template vertices). The energy is similarity invariant, so its gradient has none (no net
// force, torque or dilation); the per-vertex fits of the approximate variant do have some, which
// keeps and grows a start rotation. kAuto: kRemoveRigid for "approximate", kKeep for
// "exact".
enum class AsapNetMotion { kAuto, kKeep, kRemoveRigid, kRemoveSimilarity };
template <>
struct EnumNames<AsapNetMotion> {
  static constexpr std::array<std::pair<AsapNetMotion, const char*>, 4> table{
      {{AsapNetMotion::kAuto, "auto"}, {AsapNetMotion::kKeep, "keep"}, {AsapNetMotion::kRemoveRigid, "remove_rigid"},
       {AsapNetMotion::kRemoveSimilarity, "remove_similarity"}}};
};

// The rest shape p of E_def: the template's, or the template vertices where the phase began.
enum class AsapRest { kTemplate, kPhaseStart };
template <>
struct EnumNames<AsapRest> {
  static constexpr std::array<std::pair<AsapRest, const char*>, 2> table{
      {{AsapRest::kTemplate, "template"}, {AsapRest::kPhaseStart, "phase_start"}}};
};

struct AsapMlsOptions {
  AsapVariant variant = AsapVariant::kApproximate;
  NeighborhoodSpec neighborhood;  // JSON: "neighborhood", "k", "rings", "falloff", "weights"
  AsapIteration iteration = AsapIteration::kAuto;
  int power = 1;         // m of A3 = A2^m (steps per proposal)
  double damping = 1.0;  // lambda of A4
  AsapNetMotion net_motion = AsapNetMotion::kAuto;
  AsapRest rest = AsapRest::kTemplate;

  bool gauss_seidel() const { return iteration != AsapIteration::kJacobi; }
  AsapNetMotion resolved_net_motion() const {
    if (net_motion != AsapNetMotion::kAuto) return net_motion;
    return variant == AsapVariant::kApproximate ? AsapNetMotion::kRemoveRigid : AsapNetMotion::kKeep;
  }
  template <class V>
  void visit(V& v) {
    v(variant, Key{"variant", "", "exact D_j minimisation (§4.1-4.2) or the approximate fit of eq. (6) (§4.3)"});
    neighborhood.visit(v);
    v(iteration, Key{"iteration", "", "sweep order: jacobi (A, parallel) or gauss_seidel (A2, serial); auto: gauss_seidel, jacobi for the 3D exact variant"});
    v(power, Key{"power", "steps", "m of A3 = A2^m: operator steps per proposal", Range::at_least(1)});
    v(damping, Key{"damping", "1", "lambda of A4 = (1 - lambda) I + lambda A2", Range::open_closed(0, 1)});
    v(net_motion, Key{"net_motion", "", "the proposal's net motion (least-squares translation, rotation about the centroid, scaling; unit masses): keep it, remove the rigid part or the similarity part; auto: remove_rigid for approximate (its per-vertex fits rotate the whole shape), keep for exact"});
    v(rest, Key{"rest", "", "the rest shape p: the template's (template, the paper's) or the template vertices' positions at the start of each phase (phase_start: a refine phase keeps what the fit phase found where its forces have no evidence)"});
  }
};

template <int D>
class AsapMlsEnergy final : public Energy<D> {
 public:
  using Options = AsapMlsOptions;
  static constexpr const char* kType = "asap_mls";
  static constexpr const char* kSummary = "D-Snake's as-similar-as-possible deformation energy (§4)";

  explicit AsapMlsEnergy(const AsapMlsOptions& options = {});
  ~AsapMlsEnergy() override;

  // The dimension's own rule: the 3D exact variant moves every vertex with the others frozen.
  static void check_options(const AsapMlsOptions& o) {
    if (D == 3 && o.variant == AsapVariant::kExact && o.iteration == AsapIteration::kGaussSeidel)
      throw OptionError{"iteration", "the 3D exact variant (§4.2) moves every vertex with the others frozen: only \"jacobi\""};
  }
  // k of a k_nearest neighbourhood must leave k other template vertices.
  void check_template(const Template<D>& tmpl) const override;

  std::string type() const override { return kType; }
  Governs governs() const override { return Governs::kDeformationVertices; }
  const AsapMlsOptions& options() const { return options_; }

  // Precomputes the neighbourhoods, weights and template data (and A in 2D exact) when the
  // template changes; otherwise only the template id -> snake vertex map. The template must pass
  // check_template().
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  // With rest "phase_start": the rest shape becomes the template vertices' current positions.
  void begin_phase(const Snake<D>& snake) override;
  // out[v] for every deformation vertex v (see the variants above).
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  // E_def = sum_j D_j with the optimal constrained similarity per j (closed form in 2D, SVD in 3D).
  double value(const Snake<D>& snake) const override;
  // Per (j, i in N(j)): sqrt(weight w_ij) (M_j(q) (p_i - p_j) - (q_i - q_j)), M_j(q) the optimal
  // similarity eliminated in closed form; one block per j over the vertices {j} + N(j).
  // 2D: exact linear Jacobian; 3D: central differences.
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

  // The per-j energies D_j by template id (for tests and figures).
  std::vector<double> local_energies(const Snake<D>& snake) const;

 private:
  struct Data;
  void build(const Template<D>& rest);  // everything per template vertex, from the rest shape
  void build_quadratic();  // 2D exact: H of E_def = q^T H q (§4.1)
  void build_lanes();      // 3D: the neighbourhoods four by four, for the lane kernels
  void step();             // one application of the variant's operator to the positions by id
  AsapMlsOptions options_;
  std::unique_ptr<Data> data_;
};

}  // namespace dsnake
