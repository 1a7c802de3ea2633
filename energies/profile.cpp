// The profile force; see profile.h. Cootes et al., "Active shape models", CVIU 1995, §4.1: the
// normalised derivative profile along the normal and the search for its best match.
#include "energies/profile.h"

#include "energies/rest_positions.h"
#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace dsnake {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kFlat = 1e-12;  // a profile whose sum |dI| is below this has no edge

// d[i] /= sum |d| over the 2K values at d; false (left as is) when the profile is flat.
bool normalise_l1(double* d, int count) {
  double a = 0.0;
  for (int i = 0; i < count; ++i) a += std::abs(d[i]);
  if (!(a > kFlat)) return false;
  for (int i = 0; i < count; ++i) d[i] /= a;
  return true;
}

// The normalised derivative profile of `image` at x along n: 2K + 1 samples every h mm from
// x - K h n, their 2K differences, normalised; empty when flat.
template <int D>
std::vector<double> sample_profile(const Image<D>& image, const Point<D>& x, const Point<D>& n, double h, int half) {
  std::vector<double> s(2 * half + 1);
  for (int k = -half; k <= half; ++k) s[k + half] = image.sample(x + (k * h) * n);
  std::vector<double> d(2 * half);
  for (int i = 0; i < 2 * half; ++i) d[i] = s[i + 1] - s[i];
  if (!normalise_l1(d.data(), 2 * half)) return {};
  return d;
}

// A step edge of the polarity (sign of dI/dn) blurred by a Gaussian of sigma mm: the differences
// of sign * Phi(s / sigma) at s = k h, k = -K..K, normalised.
std::vector<double> step_profile(int sign, double sigma, double h, int half) {
  std::vector<double> d(2 * half);
  auto phi = [&](int k) { return 0.5 * std::erfc(-(k * h) / (sigma * std::sqrt(2.0))); };
  for (int k = -half; k < half; ++k) d[k + half] = sign * (phi(k + 1) - phi(k));
  normalise_l1(d.data(), 2 * half);
  return d;
}

// The mean of the non-empty profiles, normalised; empty if there is none.
std::vector<double> mean_profile(const std::vector<std::vector<double>>& profiles, int count) {
  std::vector<double> mean(count, 0.0);
  bool any = false;
  for (const auto& p : profiles) {
    if (p.empty()) continue;
    any = true;
    for (int i = 0; i < count; ++i) mean[i] += p[i];
  }
  if (!any || !normalise_l1(mean.data(), count)) return {};
  return mean;
}

// The misfit |g(d) - e|^2 of the 2K differences starting at diff, normalised on the fly; inf
// for a flat window.
double misfit(const double* diff, const std::vector<double>& expected) {
  const int count = static_cast<int>(expected.size());
  double a = 0.0;
  for (int i = 0; i < count; ++i) a += std::abs(diff[i]);
  if (!(a > kFlat)) return kInf;
  double f = 0.0;
  for (int i = 0; i < count; ++i) {
    const double r = diff[i] / a - expected[i];
    f += r * r;
  }
  return f;
}

// The best offset index in [-J, J] (smallest misfit; ties to the smallest |j|, then the smaller
// j, by visiting 0, -1, +1, -2, ...), refined by a parabola through its neighbours; in steps of h.
// NaN when every window is flat.
double best_offset(const double* misfits, int reach) {
  int best = 0;
  double fb = misfits[reach];
  for (int m = 1; m <= reach; ++m) {
    for (int j : {-m, m}) {
      if (misfits[j + reach] < fb) {
        fb = misfits[j + reach];
        best = j;
      }
    }
  }
  if (!std::isfinite(fb)) return std::numeric_limits<double>::quiet_NaN();
  double offset = best;
  if (best > -reach && best < reach) {
    const double fm = misfits[best - 1 + reach], fp = misfits[best + 1 + reach];
    const double curvature = fm - 2 * fb + fp;
    if (std::isfinite(fm) && std::isfinite(fp) && curvature > 0)
      offset += std::clamp(0.5 * (fm - fp) / curvature, -0.5, 0.5);
  }
  return offset;
}

}  // namespace

template <int D>
ProfileEnergy<D>::ProfileEnergy(const ProfileOptions& options) : options_(checked(options, kType)) {}

template <int D>
void ProfileEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  DSNAKE_ASSERT(context.image != nullptr, "the profile energy samples the image");
  const Image<D>& smoothed = image_.of(*context.image, options_.sigma, context.smoothed_images);
  if (expected_for_ != context.image) {
    h_ = options_.spacing > 0 ? options_.spacing : half_smallest_spacing(smoothed.grid());
    half_ = std::max(1, static_cast<int>(std::lround(options_.length / h_)));
    reach_ = std::max(1, static_cast<int>(std::lround(options_.search / h_)));
    set_up_expected(context, snake);
    expected_for_ = context.image;
    start_.assign(context.tmpl ? context.tmpl->num_vertices() : 0, Point<D>::Constant(kNaN));
    for (int v = 0; v < snake.num_vertices(); ++v)
      if (const int t = snake.template_id(v); t >= 0 && t < int(start_.size())) start_[t] = snake.positions()[v];
  }
  const int n = snake.num_vertices();
  profile_of_.assign(n, &mean_);
  for (int v = 0; v < n; ++v) {
    const int t = snake.template_id(v);
    if (t >= 0 && t < int(expected_.size()) && !expected_[t].empty()) profile_of_[v] = &expected_[t];
    if (t >= 0 && options_.local_polarity && !context.reference_image) profile_of_[v] = &expected_[t];
  }
  set_up_free_vertices(context, snake);
  template_of_.resize(n);
  for (int v = 0; v < n; ++v) template_of_[v] = snake.template_id(v);
  offsets_.assign(n, 0.0);
  scratch_.resize(size_t(n) * (2 * (reach_ + half_) + 1 + 2 * reach_ + 1 + 2 * half_ + 1));
  normals_.reserve(n);
}

// The expected profiles: per template vertex from the reference image at the rest positions
// (p, mapped into the reference image's frame), or the step edge of the (learned) polarity.
template <int D>
void ProfileEnergy<D>::set_up_expected(const EnergyContext<D>& context, const Snake<D>& snake) {
  expected_.clear();
  mean_.clear();
  if (context.reference_image) {
    DSNAKE_ASSERT(context.tmpl != nullptr, "a reference profile needs the template");
    const Image<D>& ref = reference_.of(*context.reference_image, options_.sigma, context.smoothed_images);
    PointList<D> p = context.tmpl->positions;
    for (auto& x : p) x = ref.grid().to_frame(x);
    const PointList<D> normals = vertex_normals<D>(p, context.tmpl->connectivity);
    expected_.resize(p.size());
    for (size_t t = 0; t < p.size(); ++t) expected_[t] = sample_profile(ref, p[t], normals[t], h_, half_);
    mean_ = mean_profile(expected_, 2 * half_);
    if (options_.reference_profile == ReferenceProfile::kMean) expected_.clear();
    if (!mean_.empty()) return;
    expected_.clear();  // a reference without any edge: fall back to the step edge
  }
  if (options_.local_polarity) {
    set_up_local_polarity(context, snake);
    return;
  }
  polarity_ = options_.polarity != EdgePolarity::kAuto ? options_.polarity
                                                        : learn_polarity(image_.image(), snake, options_.search, h_);
  mean_ = step_profile(polarity_sign(polarity_), std::max(options_.sigma, h_), h_, half_);
}

// One step edge per template vertex, of the sign of its ring's mean contrast at the start (the
// snake at the first bind carries every template vertex), or none where that contrast is weak.
template <int D>
void ProfileEnergy<D>::set_up_local_polarity(const EnergyContext<D>& context, const Snake<D>& snake) {
  const Image<D>& image = image_.image();
  const int n = snake.num_vertices();
  const PointList<D> normals = snake.vertex_normals();
  const int steps = std::max(1, static_cast<int>(std::lround(options_.search / h_)));
  std::vector<double> contrast(n, 0.0);
  for (int v = 0; v < n; ++v) {
    double inside = 0.0, outside = 0.0;
    for (int k = 1; k <= steps; ++k) {
      inside += image.sample(snake.positions()[v] - (k * h_) * normals[v]);
      outside += image.sample(snake.positions()[v] + (k * h_) * normals[v]);
    }
    contrast[v] = (inside - outside) / steps;
  }
  const double weak = gradient_noise_level(image) * 0.5 * options_.search;
  expected_.assign(context.tmpl->num_vertices(), {});
  const std::vector<double> bright = step_profile(-1, std::max(options_.sigma, h_), h_, half_);
  const std::vector<double> dark = step_profile(+1, std::max(options_.sigma, h_), h_, half_);
  for (int v = 0; v < n; ++v) {
    const int t = snake.template_id(v);
    if (t < 0) continue;
    double sum = contrast[v];
    const auto ring = snake.connectivity().neighbors(v);
    for (int w : ring) sum += contrast[w];
    const double mean = sum / double(ring.size() + 1);
    if (std::abs(mean) >= weak) expected_[t] = mean > 0 ? bright : dark;
  }
  polarity_ = EdgePolarity::kAuto;
}

// A free vertex's expected profile: the reference's at its rest position along its normal turned
// into the template's frame (per_vertex reference), or its nearest template vertex's (local
// polarity), or the mean.
template <int D>
void ProfileEnergy<D>::set_up_free_vertices(const EnergyContext<D>& context, const Snake<D>& snake) {
  const int n = snake.num_vertices();
  free_expected_.assign(n, {});
  if (snake.num_deformation_vertices() == n) return;
  if (context.reference_image && options_.reference_profile == ReferenceProfile::kPerVertex && !expected_.empty()) {
    const Image<D>& ref = reference_.image();
    const RestPositions<D> rest = rest_positions(*context.tmpl, snake);
    const PointList<D> normals = snake.vertex_normals();
    for (int v = 0; v < n; ++v) {
      if (snake.is_deformation_vertex(v)) continue;
      const Point<D> p = ref.grid().to_frame(rest.positions[v]);
      const Point<D> nrm = ref.grid().direction.transpose() * (rest.rotation[v] * normals[v]);
      free_expected_[v] = sample_profile(ref, p, nrm, h_, half_);
      if (!free_expected_[v].empty()) profile_of_[v] = &free_expected_[v];
    }
    return;
  }
  if (!context.reference_image && options_.local_polarity) {
    // Breadth-first from each free vertex to its nearest template vertex; one visited flag per
    // vertex, cleared after each search (linear in what the search touched, not in n).
    const Connectivity& c = snake.connectivity();
    std::vector<uint8_t> seen(n, 0);
    std::vector<int> queue;
    for (int v = 0; v < n; ++v) {
      if (snake.is_deformation_vertex(v)) continue;
      queue.assign(1, v);
      seen[v] = 1;
      int found = -1;
      for (size_t head = 0; head < queue.size() && found < 0; ++head)
        for (int w : c.neighbors(queue[head])) {
          if (seen[w]) continue;
          seen[w] = 1;
          queue.push_back(w);
          if (snake.is_deformation_vertex(w)) {
            found = w;
            break;
          }
        }
      for (int w : queue) seen[w] = 0;
      profile_of_[v] = found >= 0 ? &expected_[snake.template_id(found)] : &free_expected_[v];
    }
  }
}

// Samples each vertex's normal line once (2(J + K) + 1 samples), differences it, and slides the
// expected profile over the 2J + 1 offsets.
template <int D>
void ProfileEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(int(out.size()) == n && int(profile_of_.size()) == n, "bind() before propose(), one entry per vertex");
  snake.vertex_normals(normals_);
  const PointList<D>& q = snake.positions();
  const Image<D>& image = image_.image();
  const int reach = reach_, half = half_, samples = 2 * (reach_ + half_) + 1;
  const size_t stride = samples + 2 * reach + 1 + 2 * half + 1;  // samples, misfits, one more line
  const double h = h_, step = options_.step;
  // Only an image larger than the caches gains from prefetching the samples of the vertex
  // kPrefetchAhead ahead (the real liver's 25.5 M voxels: each sample a new line along its normal).
  constexpr int kPrefetchAhead = 2;
  const bool prefetch = image.num_voxels() * int64_t(sizeof(float)) > (int64_t(32) << 20);
#pragma omp parallel for schedule(static) if (n >= 64)
  for (int v = 0; v < n; ++v) {
    double* s = scratch_.data() + v * stride;
    double* misfits = s + samples;
    const Point<D>& nv = normals_[v];
    if (prefetch && v + kPrefetchAhead < n) {
      const Point<D>& qa = q[v + kPrefetchAhead];
      const Point<D>& na = normals_[v + kPrefetchAhead];
      for (int i = 0; i < samples; ++i) image.prefetch(qa + ((i - reach - half) * h) * na);
    }
    for (int i = 0; i < samples; ++i) s[i] = image.sample(q[v] + ((i - reach - half) * h) * nv);
    for (int i = 0; i + 1 < samples; ++i) s[i] = s[i + 1] - s[i];  // differences, in place
    const std::vector<double>& expected = *profile_of_[v];
    // The trust region of max_travel: the start position of the vertex's template vertex, if any.
    const int t = template_of_[v];
    const Point<D>* anchor =
        options_.max_travel > 0 && t >= 0 && t < int(start_.size()) && !std::isnan(start_[t][0]) ? &start_[t] : nullptr;
    for (int j = -reach; j <= reach; ++j) {
      const bool outside = anchor && (q[v] + (j * h) * nv - *anchor).norm() > options_.max_travel;
      misfits[j + reach] = expected.empty() || outside ? kInf : misfit(s + (j + reach), expected);
    }
    const double best = best_offset(misfits, reach);
    double offset = std::isnan(best) ? kNaN : best * h;
    double at = std::isnan(best) ? kInf : misfits[int(std::lround(best)) + reach];
    // With max_travel, the two points where the normal line leaves the ball are candidates too,
    // so that a vertex drawn outwards stops on the ball rather than on the last sample inside it.
    if (anchor) {
      const Point<D> w = q[v] - *anchor;
      const double b = nv.dot(w), disc = b * b - (w.squaredNorm() - options_.max_travel * options_.max_travel);
      for (int side : {-1, 1}) {
        const double d = disc >= 0 ? -b + side * std::sqrt(disc) : kNaN;
        if (!(std::abs(d) <= reach * h)) continue;
        double* line = misfits + 2 * reach + 1;
        for (int i = 0; i <= 2 * half; ++i) line[i] = image.sample(q[v] + (d + (i - half) * h) * nv);
        for (int i = 0; i < 2 * half; ++i) line[i] = line[i + 1] - line[i];
        const double f = expected.empty() ? kInf : misfit(line, expected);
        if (f < at) at = f, offset = d;
      }
    }
    // The evidence gate: a vertex moves only where the best match is clearly better than where it
    // stands (its misfit at most (1 - min_improvement) times the misfit at offset 0).
    if (options_.min_improvement > 0 && !std::isnan(offset)) {
      const double here = misfits[reach];
      if (std::isfinite(here) && !(at <= (1.0 - options_.min_improvement) * here)) offset = 0.0;
    }
    offsets_[v] = std::isnan(offset) ? 0.0 : offset;
    out[v] = q[v] + (step * offsets_[v]) * nv;
    if (anchor) {  // back into the ball, for a vertex that the other forces moved out of it
      const Point<D> away = out[v] - *anchor;
      if (const double r = away.norm(); r > options_.max_travel) out[v] = *anchor + (options_.max_travel / r) * away;
    }
  }
}

// E = sum_v |g_v(0) - e_v|^2: each vertex's misfit where it stands, what the search along its
// normal lowers. A flat window counts as g = 0 (misfit |e_v|^2, no edge where one is expected); a
// vertex without an expected profile counts 0. Summed serially: the same bits for any thread count.
template <int D>
double ProfileEnergy<D>::value(const Snake<D>& snake) const {
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(int(profile_of_.size()) == n, "bind() before value(), one entry per vertex");
  PointList<D> normals;
  snake.vertex_normals(normals);
  const PointList<D>& q = snake.positions();
  const Image<D>& image = image_.image();
  std::vector<double> line(2 * half_ + 1);
  double e = 0.0;
  for (int v = 0; v < n; ++v) {
    const std::vector<double>& expected = *profile_of_[v];
    if (expected.empty()) continue;
    for (int i = 0; i <= 2 * half_; ++i) line[i] = image.sample(q[v] + ((i - half_) * h_) * normals[v]);
    for (int i = 0; i < 2 * half_; ++i) line[i] = line[i + 1] - line[i];
    const double f = misfit(line.data(), expected);
    if (std::isfinite(f)) {
      e += f;
    } else {
      for (double x : expected) e += x * x;
    }
  }
  return e;
}

template class ProfileEnergy<2>;
template class ProfileEnergy<3>;

}  // namespace dsnake
