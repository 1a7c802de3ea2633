// The external energy: moves each vertex along the image force field alone,
// q^ext = q + tau F(q, n) (Levi & Gotsman, D-Snake, §3.1; Kass et al. 1988, appendix, the
// explicit external term of eqs. (19)-(20)). With the basic field of §1, F = -grad E_ext.
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <string>

namespace dsnake {

struct ExternalOptions {
  double tau = 1.0;  // step: physical displacement per unit force

  template <class V>
  void visit(V& v) {
    v(tau, Key{"tau", "mm per unit force", "step: physical displacement per unit of the field's force", Range::greater_than(0)});
  }
};

template <int D>
class ExternalEnergy final : public Energy<D> {
 public:
  using Options = ExternalOptions;
  static constexpr const char* kType = "external";
  static constexpr const char* kSummary = "the image force alone, q^ext = q + tau F(q, n) (§3.1)";

  explicit ExternalEnergy(const ExternalOptions& options = {});

  std::string type() const override { return kType; }
  const ExternalOptions& options() const { return options_; }

  // Keeps the field; context.field must be set (a programmer error otherwise).
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;

  // out[v] = q_v + tau F(q_v, n_v) for every vertex, n_v the outward unit vertex normal
  // (computed only when the field uses it). Parallel over vertices.
  void propose(const Snake<D>& snake, PointList<D>& out) override;

  // sum_v P(q_v) with the context's smooth potential if there is one, else the field's own
  // potential P >= 0 if it has one; NaN otherwise.
  double value(const Snake<D>& snake) const override;

  // r_v = sqrt(weight (P(q_v) + 1e-12)) for every vertex, P the context's smooth potential;
  // false without one.
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

 private:
  ExternalOptions options_;
  const ExternalField<D>* field_ = nullptr;
  const Potential<D>* potential_ = nullptr;
  PointList<D> normals_;  // scratch, n entries
};

}  // namespace dsnake
