// Gradient vector flow (Xu & Prince, "Snakes, shapes, and gradient vector flow", 1998), the
// diffused edge force that D-Snake builds on (Levi & Gotsman, §2): the fixed point v of
//     mu Lap v - |grad f|^2 (v - grad f) = 0
// for the edge map f = |grad(G_sigma*I)|^2 (fields/edge_map.h). The linear system and its two
// solvers (explicit reference, multigrid default) are in framework/numerics/grid_diffusion_solver.h. Physical units:
// an anisotropic image gives the field of the same object sampled isotropically.
#pragma once

#include "fields/edge_map.h"
#include "framework/numerics/grid_diffusion_solver.h"
#include "framework/core/external_field.h"

#include <string>

namespace dsnake {

struct GvfFieldOptions {
  EdgeMapOptions edge;    // JSON: "sigma", "normalize"
  GvfSolveOptions solve;  // JSON: "mu", "solver", "tolerance", "iterations", "time_step"

  template <class V>
  void visit(V& v) {
    edge.visit(v);
    solve.visit(v);
  }
  void check() const { solve.check(); }
};

template <int D>
class GvfField final : public ExternalField<D>, public CacheableField<D>, public LargeField<D> {
 public:
  using Options = GvfFieldOptions;
  static constexpr const char* kType = "gvf";
  static constexpr const char* kSummary = "gradient vector flow, Xu & Prince 1998 (D-Snake §2)";

  explicit GvfField(const GvfFieldOptions& options = {});

  std::string type() const override { return kType; }
  const GvfFieldOptions& options() const { return options_; }

  // Edge map, then the GVF solve starting from v = grad f. A constant image gives a zero field.
  // An explicit solve's step that no image could make stable (validate refuses it).
  void check_grid(const Grid<D>& grid) const override { check_explicit_step(grid, options_.solve); }
  void compute(const Image<D>& image) override;
  void compute_releasing(Image<D>&& image) override;
  // v at x, linearly interpolated (the normal is not used).
  Point<D> force(const Point<D>& x, const Point<D>& normal) const override;
  const VectorField<D>& vectors() const override { return vectors_; }
  void prefetch(const Point<D>& x, const Point<D>& normal) const override { (void)normal, vectors_.prefetch(x); }
  int64_t num_voxels() const override { return vectors_.num_voxels(); }
  double largest_vector_norm() const override { return std::numeric_limits<double>::quiet_NaN(); }
  const GvfSolveStats& stats() const { return stats_; }

  std::string save_state() const override;
  bool load_state(const Grid<D>& grid, const std::string& bytes) override;

 private:
  // The solve from an edge map (its arrays are consumed: grad f becomes the solution in place).
  void solve(EdgeMap<D>&& edges);

  GvfFieldOptions options_;
  GvfSolveStats stats_;
  VectorField<D> vectors_;
};

}  // namespace dsnake
