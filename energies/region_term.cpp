// The region term; see region_term.h. Chan & Vese, "Active contours without edges", IEEE TIP
// 2001: the fitting term of eq. (3) over two bands, the means of eq. (6), the speed of eq. (9).
#include "energies/region_term.h"

#include "framework/core/errors.h"
#include "framework/global/global_problem.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace dsnake {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kNoContrast = 1e-9;  // |c_in - c_out| below this share of |c_in| + |c_out|: flat

// a_v: half the lengths of the two edges at v (2D), a third of the areas of the triangles at v
// (3D), mm^(D-1); the measure each vertex's normal line stands for in the band integrals.
template <int D>
void vertex_measures(const Snake<D>& snake, std::vector<double>& a) {
  const PointList<D>& q = snake.positions();
  a.assign(snake.num_vertices(), 0.0);
  if constexpr (D == 2) {
    for (int v = 0; v < snake.num_vertices(); ++v) {
      const auto nb = snake.connectivity().neighbors(v);
      a[v] = 0.5 * ((q[v] - q[nb[0]]).norm() + (q[nb[1]] - q[v]).norm());
    }
  } else {
    for (const Triangle& t : snake.connectivity().triangles()) {
      const double third = (q[t[1]] - q[t[0]]).cross(q[t[2]] - q[t[0]]).norm() / 6.0;
      for (int i : t) a[i] += third;
    }
  }
}

// Whether the means are too close to tell inside from outside (including non-finite ones).
bool no_contrast(double c_in, double c_out) {
  return !(std::abs(c_in - c_out) > kNoContrast * (std::abs(c_in) + std::abs(c_out)));
}

// CV's regularised Heaviside H_2,eps(z) = 1/2 + atan(z / eps) / pi (§II-B), 1 - H and H'.
struct Heaviside {
  double value, one_minus_value, derivative;
};
Heaviside heaviside(double z, double eps) {
  const double a = std::atan(z / eps) / std::numbers::pi;
  return {0.5 + a, 0.5 - a, eps / (std::numbers::pi * (eps * eps + z * z))};
}

// The 4K residuals of one vertex's normal line x + t_k n (global view, region_term.h): for each
// sample, r_2k = scale_in (I_k - c_in) sqrt(H(s - t_k)) and r_2k+1 = scale_out (I_k - c_out)
// sqrt(1 - H(s - t_k)), s = (q - x) . n. Parameters: the means [c_in, c_out], then q. The
// Jacobians (row-major): dr/dc (4K x 2, -scale sqrt(H) or -scale sqrt(1 - H)) and dr/ds n^T (4K x D).
template <int D>
class RegionLineCost final : public ceres::CostFunction {
 public:
  struct Line {
    Point<D> anchor, normal;
    std::vector<double> samples;  // I_k at t_k = (k + 1/2 - K) h, k = 0..2K-1
    double h, scale_in, scale_out;
  };
  explicit RegionLineCost(Line line) : line_(std::move(line)) {
    set_num_residuals(2 * int(line_.samples.size()));
    mutable_parameter_block_sizes()->push_back(2);
    mutable_parameter_block_sizes()->push_back(D);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double c_in = parameters[0][0], c_out = parameters[0][1];
    const Point<D> q = Eigen::Map<const Point<D>>(parameters[1]);
    const double s = (q - line_.anchor).dot(line_.normal);
    if (!std::isfinite(s) || !std::isfinite(c_in) || !std::isfinite(c_out)) return false;
    const int count = int(line_.samples.size());
    double* dc = jacobians ? jacobians[0] : nullptr;
    double* dq = jacobians ? jacobians[1] : nullptr;
    for (int k = 0; k < count; ++k) {
      const Heaviside H = heaviside(s - (k + 0.5 - count / 2) * line_.h, line_.h);
      const double root_in = std::sqrt(H.value), root_out = std::sqrt(H.one_minus_value);
      const double in = line_.scale_in * (line_.samples[k] - c_in), out = line_.scale_out * (line_.samples[k] - c_out);
      residuals[2 * k] = in * root_in;
      residuals[2 * k + 1] = out * root_out;
      if (dc) {
        dc[4 * k] = -line_.scale_in * root_in, dc[4 * k + 1] = 0.0;
        dc[4 * k + 2] = 0.0, dc[4 * k + 3] = -line_.scale_out * root_out;
      }
      if (!dq) continue;
      const double d_in = root_in > 0 ? in * H.derivative / (2 * root_in) : 0.0;
      const double d_out = root_out > 0 ? -out * H.derivative / (2 * root_out) : 0.0;
      for (int a = 0; a < D; ++a) {
        dq[(2 * k) * D + a] = d_in * line_.normal[a];
        dq[(2 * k + 1) * D + a] = d_out * line_.normal[a];
      }
    }
    return true;
  }

 private:
  Line line_;
};

}  // namespace

// Per vertex: outward normal, measure a_v and the 2K samples I_vk along its normal line; and the
// means they give.
template <int D>
struct RegionTermEnergy<D>::Band {
  PointList<D> normals;
  std::vector<double> measures, samples;  // samples: 2K per vertex, t_k = (k + 1/2 - K) h
  double c_in = kNaN, c_out = kNaN;

  const double* line(int v, int per_side) const { return samples.data() + size_t(v) * 2 * per_side; }

  // Eq. (6) over the bands: the a_v-weighted means of the inside and outside samples. Sampled per
  // vertex in parallel, summed serially, so the means do not depend on the threads.
  void estimate(const Image<D>& image, const Snake<D>& snake, int per_side, double h) {
    const int n = snake.num_vertices(), count = 2 * per_side;
    snake.vertex_normals(normals);
    vertex_measures(snake, measures);
    samples.resize(size_t(n) * count);
    const PointList<D>& q = snake.positions();
#pragma omp parallel for schedule(static) if (n >= 64)
    for (int v = 0; v < n; ++v)
      for (int k = 0; k < count; ++k)
        samples[size_t(v) * count + k] = image.sample(q[v] + ((k + 0.5 - per_side) * h) * normals[v]);
    double total = 0.0, sum_in = 0.0, sum_out = 0.0;
    for (int v = 0; v < n; ++v) {
      const double* s = line(v, per_side);
      double in = 0.0, out = 0.0;
      for (int k = 0; k < per_side; ++k) in += s[k], out += s[per_side + k];
      total += measures[v], sum_in += measures[v] * in, sum_out += measures[v] * out;
    }
    c_in = total > 0 ? sum_in / (per_side * total) : kNaN;
    c_out = total > 0 ? sum_out / (per_side * total) : kNaN;
  }
};

template <int D>
RegionTermEnergy<D>::RegionTermEnergy(const RegionTermOptions& options)
    : options_(checked(options, kType)), band_(std::make_unique<Band>()) {}

template <int D>
RegionTermEnergy<D>::~RegionTermEnergy() = default;

template <int D>
double RegionTermEnergy<D>::c_in() const {
  return band_->c_in;
}

template <int D>
double RegionTermEnergy<D>::c_out() const {
  return band_->c_out;
}

// The smoothed image and the sampling step once per image; the means of this snake.
template <int D>
void RegionTermEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  DSNAKE_ASSERT(context.image != nullptr, "the region term samples the image");
  const Image<D>& smoothed = image_.of(*context.image, options_.sigma, context.smoothed_images);
  if (sampled_for_ != context.image) {
    const double largest = options_.spacing > 0 ? options_.spacing : half_smallest_spacing(smoothed.grid());
    samples_ = std::max(1, static_cast<int>(std::ceil(options_.band / largest - 1e-9)));
    h_ = options_.band / samples_;
    sampled_for_ = context.image;
  }
  band_->estimate(image_.image(), snake, samples_, h_);
}

// Eq. (9)'s speed at each vertex over the contrast, clamped to [-1, 1], times `step` along n.
template <int D>
void RegionTermEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  DSNAKE_ASSERT(sampled_for_ != nullptr, "bind() before propose()");
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(int(out.size()) == n, "out has one entry per vertex");
  const Image<D>& image = image_.image();
  Band& b = *band_;
  b.estimate(image, snake, samples_, h_);
  const PointList<D>& q = snake.positions();
  if (no_contrast(b.c_in, b.c_out)) {
    for (int v = 0; v < n; ++v) out[v] = q[v];
    return;
  }
  const double c_in = b.c_in, c_out = b.c_out, contrast2 = (c_in - c_out) * (c_in - c_out);
  const double lambda_in = options_.lambda_in, lambda_out = options_.lambda_out, step = options_.step;
#pragma omp parallel for schedule(static) if (n >= 64)
  for (int v = 0; v < n; ++v) {
    const double i = image.sample(q[v]);
    const double speed = (lambda_out * (i - c_out) * (i - c_out) - lambda_in * (i - c_in) * (i - c_in)) / contrast2;
    out[v] = q[v] + (step * std::clamp(speed, -1.0, 1.0)) * b.normals[v];
  }
}

// E at s = 0: this snake's samples and means (the snake need not be the bound one); summed
// serially.
template <int D>
double RegionTermEnergy<D>::value(const Snake<D>& snake) const {
  DSNAKE_ASSERT(sampled_for_ != nullptr, "bind() before value()");
  Band b;
  b.estimate(image_.image(), snake, samples_, h_);
  if (no_contrast(b.c_in, b.c_out)) return 0.0;
  double e = 0.0;
  for (int v = 0; v < snake.num_vertices(); ++v) {
    const double* s = b.line(v, samples_);
    double fit = 0.0;
    for (int k = 0; k < 2 * samples_; ++k) {
      const Heaviside H = heaviside(-(k + 0.5 - samples_) * h_, h_);
      const double in = s[k] - b.c_in, out = s[k] - b.c_out;
      fit += options_.lambda_in * H.value * in * in + options_.lambda_out * H.one_minus_value * out * out;
    }
    e += b.measures[v] * h_ * fit;
  }
  return e / ((b.c_in - b.c_out) * (b.c_in - b.c_out));
}

// The means as one shared auxiliary block, initialised to this snake's; one RegionLineCost per
// vertex with its line, samples and measure, scaled by this snake's contrast.
template <int D>
bool RegionTermEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  DSNAKE_ASSERT(sampled_for_ != nullptr, "bind() before add_residuals()");
  Band b;
  b.estimate(image_.image(), snake, samples_, h_);
  if (no_contrast(b.c_in, b.c_out)) return true;
  const double contrast = std::abs(b.c_in - b.c_out);
  const std::vector<double> means = {b.c_in, b.c_out};
  const int block = problem.add_auxiliary_block(means, AuxiliaryKind::kSharedEuclidean);
  for (int v = 0; v < snake.num_vertices(); ++v) {
    const double area = weight * b.measures[v] * h_;
    const double* s = b.line(v, samples_);
    typename RegionLineCost<D>::Line line{snake.positions()[v], b.normals[v],
                                          std::vector<double>(s, s + 2 * samples_), h_,
                                          std::sqrt(area * options_.lambda_in) / contrast,
                                          std::sqrt(area * options_.lambda_out) / contrast};
    problem.add_residual_block(new RegionLineCost<D>(std::move(line)), {block}, {v});
  }
  return true;
}

template class RegionTermEnergy<2>;
template class RegionTermEnergy<3>;

}  // namespace dsnake
