// As-rigid-as-possible energy of Sorkine & Alexa, "As-rigid-as-possible surface modeling" (SGP
// 2007), with the template as rest shape, uniform edge weights, on the template connectivity:
//   E(q) = sum_i min_{R_i rotation} sum_{j in N(i)} |(q_i - q_j) - R_i (p_i - p_j)|^2   (2D and 3D).
// Snake view (D-Snake §3.1 style): the optimal R_i of every vertex, then every vertex moved to its
// minimiser with the rotations and the other vertices frozen. Governs the template vertices.
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <memory>
#include <string>

namespace dsnake {

struct ArapOptions {
  template <class V>
  void visit(V&) {}
};

template <int D>
class ArapEnergy final : public Energy<D> {
 public:
  using Options = ArapOptions;
  static constexpr const char* kType = "arap";
  static constexpr const char* kSummary = "as-rigid-as-possible (Sorkine & Alexa 2007) on the template connectivity";

  explicit ArapEnergy(const ArapOptions& options = {});
  ~ArapEnergy() override;
  std::string type() const override { return kType; }
  Governs governs() const override { return Governs::kDeformationVertices; }
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  double value(const Snake<D>& snake) const override;
  // One block per vertex i over {i} + N(i): (q_i - q_j) - R_i(q) (p_i - p_j), R_i(q) the optimal
  // rotation in closed form (Jacobian by central differences).
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

 private:
  struct Data;
  std::unique_ptr<Data> data_;
};

}  // namespace dsnake
