// Balloon (pressure) force of Cohen, "On active contour models and balloons" (CVGIP: Image
// Understanding 1991): every vertex pushed along its outward unit normal,
//   propose: q_v + pressure n_v   (pressure > 0 inflates, < 0 deflates; physical units per step).
// Its energy is -pressure x (signed area / volume), whose negative gradient is the pressure times
// the area-weighted normal; it is not a sum of squares, so it has no residuals (global solve).
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <string>

namespace dsnake {

struct BalloonOptions {
  double pressure = 1.0;  // signed step along the normal, physical units; != 0

  template <class V>
  void visit(V& v) {
    v(pressure, Key{"pressure", "mm per iteration", "signed step along the outward normal (> 0 inflates, < 0 deflates); not 0"});
  }
  void check() const {
    if (pressure == 0) throw OptionError{"pressure", "must be a non-zero number"};
  }
};

template <int D>
class BalloonEnergy final : public Energy<D> {
 public:
  using Options = BalloonOptions;
  static constexpr const char* kType = "balloon";
  static constexpr const char* kSummary = "Cohen's balloon: a constant step along the outward normal";

  explicit BalloonEnergy(const BalloonOptions& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  double value(const Snake<D>& snake) const override;  // -pressure * signed measure

 private:
  BalloonOptions options_;
  PointList<D> normals_;
};

}  // namespace dsnake
