// The external energy: moves each vertex along the image force field alone,
// q^ext = q + tau F(q, n) (Levi & Gotsman, D-Snake, §3.1; Kass et al. 1988, appendix, the
// explicit external term of eqs. (19)-(20)). With the basic field of §1, F = -grad E_ext.
#pragma once

#include "energies/polarity.h"
#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <string>

namespace dsnake {

// What tau multiplies:
//  - kNone ("none", default, the paper's form): the field's force as computed, so tau is in mm
//    per unit of force (for the edge-map fields, whose force is in 1/mm, tau is in mm^2). Already
//    independent of the image's spacing and intensity range (the edge map is normalised and
//    differentiated in mm), but the force's scale depends on the field and on its sigma.
//  - kMax ("max"): the force divided by the field's largest magnitude |F|_max over the grid, so
//    tau is a distance in mm: the step of a vertex where the force is strongest, whatever the
//    field type, sigma, spacing or intensity range. The recipes of `dsnake init` use it.
//  - kUnit ("unit"): the force at each vertex divided by its own magnitude, so every vertex
//    steps tau mm along the field's direction (Xu & Prince's GVF snakes normalise the GVF to
//    unit vectors before deforming, IEEE TIP 1998 §IV; the paper's GVF snake of §8 is one).
//    The step does not fade where the field is weak (a thin arm's apex, far from any edge), so
//    a vertex on an edge oscillates by up to tau about it: use a tau below the tolerance sought.
//    Forces below 1e-9 |F|_max (no direction) give no step.
enum class ForceNormalization { kNone, kMax, kUnit };
template <>
struct EnumNames<ForceNormalization> {
  static constexpr std::array<std::pair<ForceNormalization, const char*>, 3> table{
      {{ForceNormalization::kNone, "none"}, {ForceNormalization::kMax, "max"}, {ForceNormalization::kUnit, "unit"}}};
};

// The polarity rule, which gives edges a side, for any field: "any" (default) leaves the
// force as the field gives it (bit-identical to the energy without the rule); otherwise at each
// vertex q with outward unit normal n and force f != 0, on the image smoothed by polarity_sigma:
//  1. the edge the force pulls q onto is the first local maximum of |dI/du| (u = f / |f|) along
//     the ray q + t u, t = 0, h, 2h, ... <= polarity_range (h half the smallest voxel size) that
//     exceeds polarity_floor times the smoothed image's noise level (the median |grad I| outside
//     exact-zero padding, at least 1% of the largest; energies/polarity.h);
//  2. if that edge's dI/dn at its place has the wrong sign for the polarity (bright_inside wants
//     dI/dn < 0: the intensity falls outwards; dark_inside wants > 0), the force is reversed,
//     -f: a wrong-polarity edge repels the vertex instead of capturing it, so that it leaves
//     that edge's basin for the next one; otherwise (a right edge, or no edge within range) f
//     stays. On a step edge of the right polarity nothing changes.
// "auto" learns the polarity once, at the first bind, from the start (energies/polarity.h, with
// a band of polarity_range).
enum class PolarityRule { kAny, kBrightInside, kDarkInside, kAuto };
template <>
struct EnumNames<PolarityRule> {
  static constexpr std::array<std::pair<PolarityRule, const char*>, 4> table{
      {{PolarityRule::kAny, "any"}, {PolarityRule::kBrightInside, "bright_inside"},
       {PolarityRule::kDarkInside, "dark_inside"}, {PolarityRule::kAuto, "auto"}}};
};

struct ExternalOptions {
  double tau = 1.0;  // step: physical displacement per unit force (or in mm with normalize "max" or "unit")
  ForceNormalization normalize = ForceNormalization::kNone;
  PolarityRule polarity = PolarityRule::kAny;
  double polarity_sigma = 1.0;  // mm
  double polarity_range = 5.0;  // mm
  double polarity_floor = 3.0;  // multiples of the image's gradient noise level

  template <class V>
  void visit(V& v) {
    v(tau, Key{"tau", "mm per unit force (normalize none); mm (normalize max or unit)",
               "step: displacement per unit of the field's force, or, with normalize max, the step in mm where the "
               "force is strongest, or, with normalize unit, the step in mm of every vertex",
               Range::greater_than(0)});
    v(normalize, Key{"normalize", "", "what tau multiplies: the field's force as computed (none) or the force divided "
                                      "by the field's largest magnitude (max, tau in mm) or by its own magnitude at each "
                                      "vertex (unit: direction only, Xu & Prince's GVF snake, tau in mm)"});
    v(polarity, Key{"polarity", "", "which edges may capture a vertex: any (the field as it is), bright_inside or "
                                    "dark_inside (a force pulling a vertex onto an edge of the other polarity is "
                                    "reversed), or auto (the polarity learned from the start)"});
    v(polarity_sigma, Key{"polarity_sigma", "mm", "polarity rule: Gaussian smoothing of the image in which edges are "
                                                  "found and their polarity read (0: none)", Range::at_least(0)});
    v(polarity_range, Key{"polarity_range", "mm", "polarity rule: how far along the force the edge it pulls to is "
                                                  "sought (and the band that auto compares)", Range::greater_than(0)});
    v(polarity_floor, Key{"polarity_floor", "1", "polarity rule: an edge counts where |dI/du| exceeds this multiple "
                                                 "of the smoothed image's noise level (median gradient magnitude "
                                                 "outside exact-zero padding, at least 1% of the largest)", Range::at_least(0)});
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

  // Keeps the field; context.field must be set (a programmer error otherwise). With normalize
  // "max", finds the field's largest force once per field.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;

  // out[v] = q_v + tau s F(q_v, n_v) for every vertex (s = 1, or 1 / |F|_max with normalize max,
  // or 1 / |F(q_v, n_v)| with normalize unit), n_v the outward unit vertex normal
  // (computed only when the field uses it). Parallel over vertices.
  void propose(const Snake<D>& snake, PointList<D>& out) override;

  // sum_v P(q_v) with the context's smooth potential if there is one, else the field's own
  // potential P >= 0 if it has one; NaN otherwise.
  double value(const Snake<D>& snake) const override;

  // r_v = sqrt(weight (P(q_v) + 1e-12)) for every vertex, P the context's smooth potential;
  // false without one.
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }
  // The factor s applied to the force (1, or 1 / |F|_max with normalize max; 1 for a zero field
  // and for normalize unit, whose factor is per vertex).
  double force_scale() const { return force_scale_; }
  // The polarity the rule applies (after auto has learned it; kAuto before the first bind and
  // with polarity "any").
  EdgePolarity polarity() const { return polarity_; }

 private:
  ExternalOptions options_;
  double force_scale_ = 1.0;
  double unit_floor_ = 0.0;  // normalize unit: forces at most this long give no step
  const ExternalField<D>* scaled_field_ = nullptr;  // the field force_scale_ (or unit_floor_) was found for
  const ExternalField<D>* field_ = nullptr;
  const Potential<D>* potential_ = nullptr;
  PointList<D> normals_;  // scratch, n entries
  // the polarity rule
  EdgePolarity polarity_ = EdgePolarity::kAuto;
  SmoothedImage<D> smoothed_;
  const Image<D>* probed_image_ = nullptr;  // the image probe_ was set up for
  PolarityProbe probe_;
  void bind_polarity(const EnergyContext<D>& context, const Snake<D>& snake);
};

}  // namespace dsnake
