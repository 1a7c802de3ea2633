// docs/extending.md's worked example of a new energy: explicit umbrella smoothing (Taubin,
// "A signal processing approach to fair surface design", SIGGRAPH 1995, the lambda step),
//   propose: q_v + lambda (mean of the one-ring of v - q_v)   for every vertex,
// with the membrane energy E(q) = 1/2 sum_edges |q_i - q_j|^2 as its value. Two files and one
// registration line: this header, umbrella_energy.cpp, and `r.template add<UmbrellaEnergy<D>>();`.
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

namespace dsnake {

struct UmbrellaOptions {
  double lambda = 0.5;  // the share of the way to the one-ring's mean moved per iteration

  template <class V>
  void visit(V& v) {
    v(lambda, Key{"lambda", "1", "share of the way to the one-ring's mean per iteration", Range::open_closed(0, 1)});
  }
};

template <int D>
class UmbrellaEnergy final : public Energy<D> {
 public:
  using Options = UmbrellaOptions;
  static constexpr const char* kType = "umbrella";
  static constexpr const char* kSummary = "explicit umbrella smoothing, Taubin 1995's lambda step";

  explicit UmbrellaEnergy(const Options& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  // Nothing to precompute: the one-rings come from the snake's connectivity at each proposal.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override {}
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  double value(const Snake<D>& snake) const override;

 private:
  Options options_;
};

}  // namespace dsnake
