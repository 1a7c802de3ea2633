// Dynamic directional gradient vector flow (Cheng & Foo, "Dynamic directional gradient vector
// flow for snakes", IEEE TIP 2006), the field D-Snake uses (Levi & Gotsman, §2.1): the edge
// force is split by the sign of the image gradient along each axis into 2D directional
// components (4 in 2D, 6 in 3D), each diffused as in GVF; a vertex samples, per axis, only the
// component whose edges agree with its outward normal. The equations are in ddgvf.cpp.
#pragma once

#include "fields/edge_map.h"
#include "framework/numerics/grid_diffusion_solver.h"
#include "framework/core/external_field.h"

#include <array>
#include <memory>
#include <mutex>
#include <string>

namespace dsnake {

// Which side of the boundary is dark: kDarkInside ("dark_inside": the image gets brighter along
// the outward normal, e.g. a lung in CT) or kBrightInside ("bright_inside").
enum class DdgvfPolarity { kDarkInside, kBrightInside };
template <>
struct EnumNames<DdgvfPolarity> {
  static constexpr std::array<std::pair<DdgvfPolarity, const char*>, 2> table{
      {{DdgvfPolarity::kDarkInside, "dark_inside"}, {DdgvfPolarity::kBrightInside, "bright_inside"}}};
};

struct DdgvfFieldOptions {
  EdgeMapOptions edge;    // JSON: "sigma", "normalize"
  GvfSolveOptions solve;  // JSON: "mu", "solver", "tolerance", "iterations", "time_step"
  DdgvfPolarity polarity = DdgvfPolarity::kDarkInside;  // JSON: "polarity"

  template <class V>
  void visit(V& v) {
    edge.visit(v);
    solve.visit(v);
    v(polarity, Key{"polarity", "", "which side of the boundary is dark: the image gets brighter along the outward "
                                    "normal (dark_inside) or darker (bright_inside)"});
  }
  void check() const { solve.check(); }
};

template <int D>
class DdgvfField final : public ExternalField<D>, public CacheableField<D>, public LargeField<D> {
 public:
  using Options = DdgvfFieldOptions;
  static constexpr const char* kType = "ddgvf";
  static constexpr const char* kSummary =
      "dynamic directional gradient vector flow, Cheng & Foo 2006, the field D-Snake uses (§2.1)";

  explicit DdgvfField(const DdgvfFieldOptions& options = {});

  std::string type() const override { return kType; }
  const DdgvfFieldOptions& options() const { return options_; }

  // Edge map, image gradient, then 2D scalar GVF solves (one per axis and sign).
  // An explicit solve's step that no image could make stable (validate refuses it).
  void check_grid(const Grid<D>& grid) const override { check_explicit_step(grid, options_.solve); }
  void compute(const Image<D>& image) override;
  void compute_releasing(Image<D>&& image) override;
  // Per axis a, the component of sign(normal_a) (n_a = 0 counts as +), linearly interpolated.
  Point<D> force(const Point<D>& x, const Point<D>& normal) const override;
  bool uses_normal() const override { return true; }
  // The voxels force(x, normal) reads: per axis, those of the component chosen by the normal.
  void prefetch(const Point<D>& x, const Point<D>& normal) const override;
  // The polarity-blind field, sum of both signs per axis (for figures).
  // Made on first use (a run that only samples forces does not hold it).
  const VectorField<D>& vectors() const override;
  int64_t num_voxels() const override { return components_[0][0].num_voxels(); }
  // max |F| of vectors(), computed from the components without making them (the same value).
  double largest_vector_norm() const override;
  // Component of axis a and sign s (0: +, 1: -) on the grid.
  const Image<D>& component(int axis, int sign) const { return components_[axis][sign]; }

  std::string save_state() const override;
  bool load_state(const Grid<D>& grid, const std::string& bytes) override;

 private:
  // The 2 D directional solves from an edge map with the image gradient (its arrays are consumed).
  void solve(EdgeMap<D>&& edges);

  // Drops the summed vectors; the next vectors() makes them from the components.
  void reset_vectors();
  // Axis a of vectors() at voxel l: both signs' components summed in double, rounded to float.
  float summed(int a, int64_t l) const { return float(double(components_[a][0][l]) + components_[a][1][l]); }

  DdgvfFieldOptions options_;
  std::array<std::array<Image<D>, 2>, D> components_;
  mutable VectorField<D> vectors_;
  mutable std::unique_ptr<std::once_flag> vectors_made_;
};

}  // namespace dsnake
