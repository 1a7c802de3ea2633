// The region term: Chan & Vese's two-phase piecewise-constant model ("Active contours without
// edges", IEEE TIP 10(2), 2001), restricted to two bands along the contour/mesh. The fitting term
// of their eq. (3), lambda_1 int_inside (I - c_1)^2 + lambda_2 int_outside (I - c_2)^2, is taken
// over the band of width `band` mm just inside and the band just outside (not the whole interior
// and exterior): a scan's outside is the rest of the image and an organ's inside is rarely one
// level, so the means describe the intensities next to the boundary (the localised model of
// Lankton & Tannenbaum, IEEE TIP 2008), both sides are estimated alike (on a blurred straight step
// both means are biased by the same amount, so the balance point stays the half level), and the
// cost is O(vertices x samples) per iteration, not O(voxels). The band should stay below the
// object's half-thickness (deeper inside samples reach the far side).
// On the image smoothed by `sigma` (sampled linearly, image.h), with outward unit normals n_v,
// vertex measures a_v (half the adjacent edge lengths in 2D, a third of the adjacent triangle
// areas in 3D), K = ceil(band / spacing) samples per side at the 2K offsets t_k = (k + 1/2 - K) h,
// k = 0..2K-1, h = band / K (the midpoint rule over [-band, band]; t < 0 inside), and the samples
// I_vk = I(q_v + t_k n_v):
//  - c_in, c_out: the a_v-weighted means of the inside (t_k < 0) and outside samples (eq. (6): the
//    minimisers of the fitting term for a fixed contour), re-estimated at every propose(), as CV's
//    algorithm recomputes c_1, c_2 before each step of phi; after bind(), the bound snake's.
//  - Snake view: the normal speed of CV's descent (eq. (9): d phi/dt ~ -lambda_1 (I - c_1)^2 +
//    lambda_2 (I - c_2)^2, phi > 0 inside) over the contrast (c_in - c_out)^2, so that it does not
//    change when I becomes a I + b (a != 0: no polarity to set):
//      v = (lambda_out (I(q) - c_out)^2 - lambda_in (I(q) - c_in)^2) / (c_in - c_out)^2,
//    propose q + step clamp(v, -1, 1) n. With unit lambdas v = 1 where I(q) = c_in, -1 where
//    I(q) = c_out and 2 (I(q) - (c_in + c_out) / 2) / (c_in - c_out) between: it grows where the
//    pixel fits the inside better and rests where both fit equally. No contrast (|c_in - c_out| <=
//    1e-9 (|c_in| + |c_out|)): no move.
//  - Global view: CV's regularised functional (§II-B, their H_2,eps(z) = 1/2 + atan(z / eps) / pi,
//    eps = h) on the band about the snake at the solve's start, each normal line a 1D level set
//    phi = s_v - t (s_v: the vertex's offset along its line), minimised over the positions and the
//    means together (as CV minimise F over c_1, c_2 and phi):
//      E = sum_v a_v h sum_k [lambda_in H(s_v - t_k) (I_vk - c_in)^2
//                             + lambda_out (1 - H(s_v - t_k)) (I_vk - c_out)^2] / C^2,
//    mm^D, C = |c_in - c_out| of the start (a constant unit of intensity). value() is E at s = 0
//    with this snake's samples and means. Residuals: one block of 4K per vertex,
//      r = sqrt(weight a_v h lambda_in H(s - t_k)) (I_vk - c_in) / C and the same with lambda_out,
//      1 - H and c_out,  s = (q_v - x_v) . n_v,
//    over the vertex and one shared block [c_in, c_out] (started at the means; kept out of the
//    Schur elimination, global_problem.h). The line (x_v, n_v, a_v, I_vk) is frozen when they are
//    added (the solver adds them again after a remesh), so r is smooth in s and c with an exact
//    Jacobian. (A window moving with q_v instead would add terms from the band's ends to the
//    gradient, which from a start off the edge push the wrong way.) Its descent is the
//    delta_eps-smoothed CV speed, -dE/ds_v = a_v h sum_k delta_eps(s_v - t_k) (lambda_out
//    (I_vk - c_out)^2 - lambda_in (I_vk - c_in)^2) / C^2, about a_v v: the two views share the
//    fixed point (tested), but the global view's band stays where the solve started, and on a
//    blurred edge CV's fit of an off-centre band splits short of the edge: from 1 mm off it ends
//    0.6 mm off (blur 1.8 mm, band 3 mm). It polishes a snake phase's result rather than capturing.
#pragma once

#include "energies/polarity.h"
#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <memory>
#include <string>

namespace dsnake {

struct RegionTermOptions {
  double sigma = 1.0;     // mm
  double band = 3.0;      // mm
  double spacing = 0.0;   // mm; 0: half the smallest voxel size
  double step = 0.5;      // mm
  double lambda_in = 1.0;
  double lambda_out = 1.0;

  template <class V>
  void visit(V& v) {
    v(sigma, Key{"sigma", "mm", "Gaussian smoothing of the image before sampling (0: none)", Range::at_least(0)});
    v(band, Key{"band", "mm", "width of the bands inside and outside the contour/mesh over which the mean "
                              "intensities are estimated and the fit is measured (below the object's half-thickness)",
                Range::greater_than(0)});
    v(spacing, Key{"spacing", "mm", "largest sampling step along the normals (0: half the smallest voxel size)",
                   Range::at_least(0)});
    v(step, Key{"step", "mm", "largest move per iteration (where a vertex's intensity is at or beyond a mean)",
                Range::greater_than(0)});
    v(lambda_in, Key{"lambda_in", "1", "Chan-Vese lambda_1: weight of the inside fit", Range::greater_than(0)});
    v(lambda_out, Key{"lambda_out", "1", "Chan-Vese lambda_2: weight of the outside fit", Range::greater_than(0)});
  }
};

template <int D>
class RegionTermEnergy final : public Energy<D> {
 public:
  using Options = RegionTermOptions;
  static constexpr const char* kType = "region";
  static constexpr const char* kSummary =
      "Chan-Vese region term over bands along the normals: q + step clamp(v) n, v the normalised CV speed";

  explicit RegionTermEnergy(const RegionTermOptions& options = {});
  ~RegionTermEnergy() override;
  std::string type() const override { return kType; }
  const RegionTermOptions& options() const { return options_; }

  // Smooths the image (once per image), sets the sampling step and estimates the means on this
  // snake. context.image must be set.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  // Re-estimates the means, then out[v] = q_v + step clamp(v_v, -1, 1) n_v for every vertex;
  // parallel over vertices, the same bits for any thread count (serial sums).
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  // E above at this snake (s = 0, its own samples and means), mm^D; 0 without contrast.
  double value(const Snake<D>& snake) const override;
  // One block of 4K residuals per vertex and a shared block of the means (above); none without
  // contrast.
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

  // The band means of the last bind() or propose() (intensity units).
  double c_in() const;
  double c_out() const;
  // Samples per side of each normal (K) and their step h = band / K, mm; after bind().
  int samples() const { return samples_; }
  double sample_step() const { return h_; }

 private:
  struct Band;  // per-vertex normals, measures and samples (region_term.cpp)
  RegionTermOptions options_;
  SmoothedImage<D> image_;
  const Image<D>* sampled_for_ = nullptr;  // the image h_ and samples_ were set for
  double h_ = 0.0;
  int samples_ = 0;
  std::unique_ptr<Band> band_;
};

}  // namespace dsnake
