// Potentials for the global (Ceres) solve. The snake of Levi & Gotsman (D-Snake, §3.1,
// §4) only needs forces, but a global least-squares solve needs an energy whose gradient is the
// force: E_ext(x) = P(x) with F = -grad P. GVF, DDGVF and VFC (§2) are not gradients of any
// potential, so three are offered:
//   "edge":       the classical edge potential -|grad(G_sigma * I)|^2 (§1; Kass, Witkin and
//                 Terzopoulos 1988), normalised by its maximum and shifted: P = max f - f = 1 - f;
//   "distance":   the distance (physical units) to the nearest edge voxel (Cohen & Cohen 1993),
//                 edges as in fields/distance.h;
//   "integrated": the P whose negative gradient best matches the field's sampled vectors in
//                 least squares (a Neumann Poisson problem, solved exactly with a DCT).
// SmoothPotential interpolates a potential smoothly (C^1 cubic, or linear) with exact
// derivatives, for Ceres' residuals and its GradientChecker.
#pragma once

#include "framework/core/external_field.h"
#include "framework/core/image.h"
#include "framework/core/options.h"
#include "framework/core/potential.h"

#include <memory>
#include <string>
#include <vector>

namespace dsnake {

// The three potentials above: kEdge ("edge"), kDistance ("distance"), kIntegrated ("integrated").
enum class PotentialType { kEdge, kDistance, kIntegrated };
template <>
struct EnumNames<PotentialType> {
  static constexpr std::array<std::pair<PotentialType, const char*>, 3> table{
      {{PotentialType::kEdge, "edge"}, {PotentialType::kDistance, "distance"}, {PotentialType::kIntegrated, "integrated"}}};
};
// SmoothPotential's interpolation (below): kCubic ("cubic", Catmull-Rom) or kLinear ("linear").
enum class PotentialInterpolation { kCubic, kLinear };
template <>
struct EnumNames<PotentialInterpolation> {
  static constexpr std::array<std::pair<PotentialInterpolation, const char*>, 2> table{
      {{PotentialInterpolation::kCubic, "cubic"}, {PotentialInterpolation::kLinear, "linear"}}};
};

// The keys "potential", "interpolation" and "sigma" of an experiment's "global" object (all
// optional); read with read_options<PotentialOptions>(reader), which does not call
// reader.finish() (the caller's object holds other keys).
struct PotentialOptions {
  PotentialType type = PotentialType::kIntegrated;                       // JSON "potential"
  PotentialInterpolation interpolation = PotentialInterpolation::kCubic;  // JSON "interpolation"
  double sigma = 1.0;  // JSON "sigma": Gaussian pre-smoothing of the edge map ("edge" and
                       // "distance"), standard deviation in physical units

  template <class V>
  void visit(V& v) {
    v(type, Key{"potential", "", "the external term's potential: the edge potential 1 - f (§1), the distance to the "
                                 "nearest edge, or the least-squares integral of the field"});
    v(interpolation, Key{"interpolation", "", "interpolation of the potential between voxels: C^1 Catmull-Rom cubic or linear"});
    v(sigma, Key{"sigma", "mm", "edge and distance potentials: Gaussian pre-smoothing of the image before the edge map, "
                                "standard deviation (0: none)", Range::at_least(0)});
  }
};

// The potential P on the image grid, P >= 0 with min P = 0 (all zero for an image without
// edges or a zero field). `field` (computed on `image`'s grid) is used by "integrated" only
// and may be null otherwise; "integrated" reads only the field (on its grid), so `image` may
// then be empty (a caller that has released it). For a field with uses_normal() (DDGVF), vectors() is the
// polarity-blind field (both signs summed per axis), so "integrated" integrates that field,
// without DDGVF's normal test. Deterministic for any thread count.
template <int D>
Image<D> compute_potential(const PotentialOptions& options, const Image<D>& image, const ExternalField<D>* field);

// The least-squares integration behind "integrated", in double precision: P on field.grid()
// minimising, over all grid edges (x, x + e_a),
//     sum ((P[x + e_a] - P[x]) / h_a + (F_a[x] + F_a[x + e_a]) / 2)^2,
// i.e. -grad P ~ F with the force averaged onto the edge. The normal equations are the Neumann
// Poisson problem  L P = div g  (L the 2D+1-point Laplacian with zero-flux borders, g the edge
// targets), solved exactly with a DCT-II / DCT-III pair (FFTW REDFT10 / REDFT01), eigenvalues
// sum_a 4 sin^2(pi k_a / (2 N_a)) / h_a^2, the constant mode set to zero; then shifted so that
// min P = 0. x fastest, like the grid. Deterministic for any thread count.
template <int D>
std::vector<double> integrate_field(const VectorField<D>& field);

// A potential given on a grid, interpolated in physical coordinates (origin, spacing) with
// derivatives exactly consistent with the value:
//   "cubic":  Catmull-Rom (cubic Hermite with central-difference slopes, Keys' kernel, a = -0.5),
//             C^1; reproduces quadratics exactly away from the border. 2D uses Ceres'
//             BiCubicInterpolator on a Grid2D (row = y, col = x); 3D applies the same 1D kernel
//             separably (tricubic).
//   "linear": (bi/tri)linear, piecewise exact derivatives (the gradient jumps across cells).
// Outside the grid, indices are clamped the way Ceres' Grid2D does: the cubic blends to the
// border value within one voxel beyond the outermost voxel centres and is constant (zero
// gradient) further out; the linear one is the value at the nearest point of the grid's box.
// Immutable after construction; copies share the data; const methods are thread-safe.
template <int D>
class SmoothPotential final : public Potential<D> {
 public:
  SmoothPotential(const Image<D>& values, const std::string& interpolation);
  // values: one per voxel of `grid`, x fastest.
  SmoothPotential(const Grid<D>& grid, std::vector<double> values, const std::string& interpolation);

  const Grid<D>& grid() const;
  const std::string& interpolation() const;

  // P(x), x in physical units. NaN for a non-finite x.
  double value(const Point<D>& x) const override;
  // P(x) and dP/dx (1 / physical unit) in `gradient`.
  double value_and_gradient(const Point<D>& x, Point<D>& gradient) const override;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

// The potential an experiment's "global" object asks for, ready to sample: compute_potential on
// the image grid, interpolated as options.interpolation says.
template <int D>
std::unique_ptr<SmoothPotential<D>> make_potential(const PotentialOptions& options, const Image<D>& image,
                                                   const ExternalField<D>* field);

}  // namespace dsnake
