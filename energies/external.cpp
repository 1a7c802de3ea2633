// External energy; see external.h. Levi & Gotsman, D-Snake, §1 (E_ext) and §3.1 (q^ext).
#include "energies/external.h"

#include "framework/core/errors.h"
#include "energies/residual_blocks.h"
#include "framework/core/external_field.h"
#include "framework/core/force_strength.h"
#include "framework/core/potential.h"

#include <limits>

namespace dsnake {

template <int D>
ExternalEnergy<D>::ExternalEnergy(const ExternalOptions& options) : options_(checked(options, kType)) {}

template <int D>
void ExternalEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  DSNAKE_ASSERT(context.field != nullptr, "the external energy is bound to a computed field");
  field_ = context.field;
  potential_ = context.potential;
  if (options_.normalize == ForceNormalization::kMax && scaled_field_ != field_) {
    const double m = max_force_magnitude(*field_);
    force_scale_ = m > 0 ? 1.0 / m : 1.0;
    scaled_field_ = field_;
  } else if (options_.normalize == ForceNormalization::kUnit && scaled_field_ != field_) {
    unit_floor_ = 1e-9 * max_force_magnitude(*field_);
    scaled_field_ = field_;
  }
  normals_.reserve(snake.num_vertices());
  if (options_.polarity != PolarityRule::kAny) bind_polarity(context, snake);
}

// The polarity rule's precomputation: the smoothed image, the noise floor and the ray step once
// per image, and with "auto" the polarity, learned from the snake at its first bind (the start).
template <int D>
void ExternalEnergy<D>::bind_polarity(const EnergyContext<D>& context, const Snake<D>& snake) {
  DSNAKE_ASSERT(context.image != nullptr, "the polarity rule samples the image");
  const Image<D>& smoothed = smoothed_.of(*context.image, options_.polarity_sigma, context.smoothed_images);
  if (probed_image_ != context.image) {
    probe_.step = half_smallest_spacing(smoothed.grid());
    probe_.range = options_.polarity_range;
    probe_.floor = options_.polarity_floor * gradient_noise_level(smoothed);
    probed_image_ = context.image;
  }
  if (polarity_ == EdgePolarity::kAuto) {
    polarity_ = options_.polarity == PolarityRule::kBrightInside ? EdgePolarity::kBrightInside
                : options_.polarity == PolarityRule::kDarkInside ? EdgePolarity::kDarkInside
                                                                 : learn_polarity(smoothed, snake, options_.polarity_range, probe_.step);
  }
  probe_.sign = polarity_sign(polarity_);
}

// §3.1: q_i^ext(t+1) = q_i(t) + tau F_ext(q_i(t)), the force scaled by force_scale_.
// How many vertices ahead the sampling loop prefetches a field's voxels (a latency-hiding hint).
constexpr int kPrefetchAhead = 8;
constexpr int64_t kPrefetchMinBytes = int64_t(32) << 20;

template <int D>
void ExternalEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  DSNAKE_ASSERT(field_ != nullptr, "bind() before propose()");
  const PointList<D>& q = snake.positions();
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(int(out.size()) == n, "out has one entry per vertex");
  const bool polarised = options_.polarity != PolarityRule::kAny;
  const bool with_normals = field_->uses_normal();
  if (with_normals || polarised) snake.vertex_normals(normals_);
  const ExternalField<D>& field = *field_;
  const double tau = options_.tau * force_scale_;
  const PointList<D>& normals = normals_;
  // only a field larger than the caches gains from prefetching; a small one pays for the hint
  const bool prefetch = field_voxels(field) * int64_t(sizeof(Point<D>)) > kPrefetchMinBytes;
  const LargeField<D>* large = as_large(field);
  const bool unit = options_.normalize == ForceNormalization::kUnit;
  const double floor = unit_floor_;
  const Image<D>& smoothed = smoothed_.image();
  const PolarityProbe& probe = probe_;
#pragma omp parallel for schedule(static) if (n >= 256)
  for (int v = 0; v < n; ++v) {
    if (prefetch && v + kPrefetchAhead < n)
      prefetch_force(field, large, q[v + kPrefetchAhead], with_normals ? normals[v + kPrefetchAhead] : Point<D>::Zero());
    const Point<D> normal = with_normals ? normals[v] : Point<D>::Zero();
    Point<D> f = field.force(q[v], normal);
    if (polarised) f *= polarity_factor(smoothed, probe, q[v], normals[v], f);
    if (!unit) {
      out[v] = q[v] + tau * f;
    } else {
      const double length = f.norm();
      out[v] = length > floor ? Point<D>(q[v] + (tau / length) * f) : q[v];
    }
  }
}

// E_ext(q) = sum_v P(q_v); summed serially so that the value does not depend on the threads.
template <int D>
double ExternalEnergy<D>::value(const Snake<D>& snake) const {
  DSNAKE_ASSERT(field_ != nullptr, "bind() before value()");
  double e = 0.0;
  if (potential_) {
    for (const Point<D>& x : snake.positions()) e += potential_->value(x);
  } else if (field_->has_potential()) {
    for (const Point<D>& x : snake.positions()) e += field_->potential(x);
  } else {
    e = std::numeric_limits<double>::quiet_NaN();
  }
  return e;
}

template <int D>
bool ExternalEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  if (!potential_) return false;
  for (int v = 0; v < snake.num_vertices(); ++v) add_potential_residual<D>(problem, v, *potential_, weight);
  return true;
}

template class ExternalEnergy<2>;
template class ExternalEnergy<3>;

}  // namespace dsnake
