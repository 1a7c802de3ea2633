// Laplacian surface editing energy of Sorkine, Cohen-Or, Lipman, Alexa, Rössl, Seidel, "Laplacian
// surface editing" (SGP 2004), on the template connectivity (2D contour or 3D mesh):
//   E(q) = sum_i |T_i(q) delta_i - L(q)_i|^2,
// delta_i = L(p)_i the umbrella delta-coordinate of the template, L(q)_i = q_i - mean of the
// one-ring, and T_i the linearised similarity s I + [h]_x (3D) / s I + h J (2D) fitted by least
// squares to the one-ring plus i (p -> q), which is linear in q: E is a quadratic form q^T H q.
// Snake view: one Jacobi (one vertex moves, the others frozen) or Gauss-Seidel sweep on H, as the
// ASAP operator of D-Snake §4.1. Governs the template vertices (like ASAP, §6).
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <memory>
#include <string>

namespace dsnake {

// The order of a sweep over the vertices: all from the old positions (parallel), or one at a
// time from the newest (serial).
enum class LaplacianIteration { kJacobi, kGaussSeidel };
template <>
struct EnumNames<LaplacianIteration> {
  static constexpr std::array<std::pair<LaplacianIteration, const char*>, 2> table{
      {{LaplacianIteration::kJacobi, "jacobi"}, {LaplacianIteration::kGaussSeidel, "gauss_seidel"}}};
};

struct LaplacianOptions {
  LaplacianIteration iteration = LaplacianIteration::kJacobi;

  template <class V>
  void visit(V& v) {
    v(iteration, Key{"iteration", "", "sweep order: every vertex from the old positions, or one at a time"});
  }
};

template <int D>
class LaplacianEnergy final : public Energy<D> {
 public:
  using Options = LaplacianOptions;
  static constexpr const char* kType = "laplacian";
  static constexpr const char* kSummary = "Laplacian coordinates of the template, rotated per vertex (Sorkine et al. 2004)";

  explicit LaplacianEnergy(const LaplacianOptions& options = {});
  ~LaplacianEnergy() override;
  std::string type() const override { return kType; }
  Governs governs() const override { return Governs::kDeformationVertices; }
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  double value(const Snake<D>& snake) const override;
  // One block of D residuals per template vertex: T_i(q) delta_i - L(q)_i (linear in q).
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

 private:
  struct Data;
  LaplacianOptions options_;
  std::unique_ptr<Data> data_;
};

}  // namespace dsnake
