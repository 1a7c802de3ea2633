// NCC image alignment by variable-projection Levenberg-Marquardt; see image_alignment.h.
#include "framework/core/image_alignment.h"

#include "framework/core/alignment.h"
#include "framework/core/image_filters.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>

namespace dsnake {

void ImageAlignmentOptions::check() const {
  if (max_scale != 0 && !(max_scale >= 1)) throw OptionError{"max_scale", "expected 0 (no bound) or a ratio >= 1"};
  if (levels.empty()) throw OptionError{"levels", "expected at least one smoothing level (mm)"};
  for (double s : levels)
    if (!std::isfinite(s) || s < 0) throw OptionError{"levels", "every level must be a finite sigma >= 0 (mm)"};
}

namespace {

template <int D>
using Matrix = Eigen::Matrix<double, D, D>;

// The parameters of the increment Delta(x) = c + L (x - c) + dt about the region's centre c:
// translation (D), then rigid: rotation (1 angle in 2D, a rotation vector in 3D); similarity:
// also the log of the scale; affine: instead of both, the D x D entries of L - I.
template <int D>
int parameter_count(AlignmentModel m) {
  constexpr int kRot = D == 2 ? 1 : 3;
  switch (m) {
    case AlignmentModel::kRigid: return D + kRot;
    case AlignmentModel::kSimilarity: return D + kRot + 1;
    case AlignmentModel::kAffine: return D + D * D;
  }
  return 0;
}

// The linear part L of the increment for parameters p (translation first).
template <int D>
Matrix<D> increment_matrix(AlignmentModel m, const Eigen::VectorXd& p) {
  Matrix<D> L = Matrix<D>::Identity();
  if (m == AlignmentModel::kAffine) {
    for (int j = 0; j < D; ++j)
      for (int k = 0; k < D; ++k) L(j, k) += p[D + D * j + k];
    return L;
  }
  if constexpr (D == 2) {
    L = Eigen::Rotation2Dd(p[D]).toRotationMatrix();
  } else {
    const Point<3> w = p.segment<3>(D);
    if (w.norm() > 0) L = Eigen::AngleAxisd(w.norm(), w / w.norm()).toRotationMatrix();
  }
  if (m == AlignmentModel::kSimilarity) L *= std::exp(p[parameter_count<D>(m) - 1]);
  return L;
}

// d Delta(x) / d p at p = 0 contracted with u (the moving image's world gradient pulled back
// through the current matrix, u = A^T grad S): row[k] = u . d Delta / d p_k, z = x - c.
template <int D>
void jacobian_row(AlignmentModel m, const Point<D>& u, const Point<D>& z, double* row) {
  for (int a = 0; a < D; ++a) row[a] = u[a];
  if (m == AlignmentModel::kAffine) {
    for (int j = 0; j < D; ++j)
      for (int k = 0; k < D; ++k) row[D + D * j + k] = u[j] * z[k];
    return;
  }
  if constexpr (D == 2) {
    row[D] = -u[0] * z[1] + u[1] * z[0];  // d (R(w) z) / dw = (-z_y, z_x)
  } else {
    const Point<3> c = z.cross(u);  // u . (e_k x z) = e_k . (z x u)
    for (int k = 0; k < 3; ++k) row[D + k] = c[k];
  }
  if (m == AlignmentModel::kSimilarity) row[parameter_count<D>(m) - 1] = u.dot(z);  // d (e^s z) / ds
}

template <int D>
std::array<Point<D>, (1 << D)> corners(const WorldBox<D>& b) {
  std::array<Point<D>, (1 << D)> c;
  for (int k = 0; k < (1 << D); ++k)
    for (int a = 0; a < D; ++a) c[k][a] = (k >> a) & 1 ? b.hi[a] : b.lo[a];
  return c;
}

// The voxels of `grid` whose frame box covers the world points, widened by `pad` mm; false
// when that is outside the grid.
template <int D>
bool voxel_range(const Grid<D>& g, const std::vector<Point<D>>& points, double pad, GridIndex<D>& lo, GridIndex<D>& hi) {
  Point<D> clo = Point<D>::Constant(std::numeric_limits<double>::infinity()), chi = -clo;
  for (const Point<D>& p : points) {
    const Point<D> c = g.to_continuous_index(g.to_frame(p));
    clo = clo.cwiseMin(c), chi = chi.cwiseMax(c);
  }
  for (int a = 0; a < D; ++a) {
    const double v = pad / g.spacing[a];
    const double l = std::max(std::floor(clo[a] - v), 0.0), h = std::min(std::ceil(chi[a] + v), double(g.size[a] - 1));
    if (!(l <= h)) return false;
    lo[a] = int(l), hi[a] = int(h);
  }
  return true;
}

// The voxels lo..hi (inclusive) of an image, on the same spacing and direction.
template <int D>
Image<D> crop_voxels(const Image<D>& image, const GridIndex<D>& lo, const GridIndex<D>& hi) {
  Grid<D> g = image.grid();
  g.size = hi - lo + GridIndex<D>::Ones();
  g.origin = image.grid().to_world(image.grid().to_physical(lo));
  Image<D> out(g);
  const int64_t n = g.size[0], rows = out.num_voxels() / n;
  for (int64_t row = 0; row < rows; ++row) {  // row by row along x
    GridIndex<D> idx = lo;
    int64_t rest = row;
    for (int a = 1; a < D; ++a) idx[a] += int(rest % g.size[a]), rest /= g.size[a];
    std::copy_n(image.data().begin() + image.grid().linear(idx), n, out.data().begin() + row * n);
  }
  return out;
}

// One level's data: the fixed samples (z = x - c, world mm, and R's value) and the smoothed
// moving image with its gradient (frame axes).
template <int D>
struct Level {
  std::vector<Point<D>> z;
  std::vector<double> r;
  double r_mean = 0, r_ss = 0;  // mean and sum of squared deviations of r
  Image<D> moving;
  VectorField<D> grad;
  Grid<D> full;  // the whole moving image's grid: overlap is judged on it
};

// The contrast fit and NCC of a map: S at every sample, a and b of the linear fit of r on S.
struct Fit {
  double ncc = 0, overlap = 0, a = 0, b = 0;
  bool finite = false;
  double score() const { return ncc * ncc; }  // what the least squares maximise (1 - cost / r_ss)
};

constexpr int64_t kBlock = 2048;  // samples per partial sum: the sums' order, whatever the threads

template <int D>
Fit evaluate(const Level<D>& lv, const AffineMap<D>& T, const Point<D>& c) {
  const int64_t n = int64_t(lv.z.size());
  const int64_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<std::array<double, 4>> part(static_cast<size_t>(blocks));  // sum m, sum m^2, sum r m, inside
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < blocks; ++b) {
    std::array<double, 4> s{0, 0, 0, 0};
    for (int64_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
      const Point<D> y = T.apply(Point<D>(lv.z[i] + c));
      const double m = lv.moving.sample(lv.moving.grid().to_frame(y));
      s[0] += m, s[1] += m * m, s[2] += (lv.r[i] - lv.r_mean) * m;
      s[3] += lv.full.inside(lv.full.to_frame(y)) ? 1.0 : 0.0;
    }
    part[size_t(b)] = s;
  }
  std::array<double, 4> s{0, 0, 0, 0};
  for (const auto& p : part)
    for (int k = 0; k < 4; ++k) s[k] += p[k];
  Fit f;
  f.overlap = n > 0 ? s[3] / double(n) : 0.0;
  const double m_mean = s[0] / double(n), m_ss = s[1] - double(n) * m_mean * m_mean;
  f.finite = std::isfinite(s[0]) && std::isfinite(s[1]) && std::isfinite(s[2]);
  if (!f.finite || !(m_ss > 0) || !(lv.r_ss > 0)) return f;
  f.ncc = std::clamp(s[2] / std::sqrt(m_ss * lv.r_ss), -1.0, 1.0);  // |NCC| <= 1 (Cauchy-Schwarz), up to round-off
  f.a = s[2] / m_ss;  // the least-squares contrast and offset: r ~ a m + b
  f.b = lv.r_mean - f.a * m_mean;
  return f;
}

// The Gauss-Newton normal equations of the residuals e_i = r_i - a S(T Delta_p(x_i)) - b in
// (p, a, b) at p = 0: H = J^T J and g = J^T e, J's rows [a u^T dDelta/dp, S, 1].
template <int D>
void normal_equations(const Level<D>& lv, const AffineMap<D>& T, const Point<D>& c, AlignmentModel model,
                      const Fit& fit, Eigen::MatrixXd& H, Eigen::VectorXd& g) {
  const int np = parameter_count<D>(model), n = np + 2;
  const int64_t count = int64_t(lv.z.size());
  const int64_t blocks = (count + kBlock - 1) / kBlock;
  const Matrix<D> At = T.matrix.transpose(), dir = lv.moving.grid().direction;
  std::vector<Eigen::MatrixXd> partH(static_cast<size_t>(blocks));
  std::vector<Eigen::VectorXd> partg(static_cast<size_t>(blocks));
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < blocks; ++b) {
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd v = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd row(n);
    for (int64_t i = b * kBlock; i < std::min(count, (b + 1) * kBlock); ++i) {
      const Point<D> y = T.apply(Point<D>(lv.z[i] + c));
      const Point<D> f = lv.moving.grid().to_frame(y);
      const double m = lv.moving.sample(f);
      const Point<D> u = At * (dir * lv.grad.sample(f));  // A^T times S's world gradient
      jacobian_row<D>(model, u, lv.z[i], row.data());
      row.head(np) *= fit.a;
      row[np] = m, row[np + 1] = 1.0;
      const double e = lv.r[i] - fit.a * m - fit.b;
      h.template selfadjointView<Eigen::Upper>().rankUpdate(row);
      v += e * row;
    }
    partH[size_t(b)] = std::move(h), partg[size_t(b)] = std::move(v);
  }
  H = Eigen::MatrixXd::Zero(n, n), g = Eigen::VectorXd::Zero(n);
  for (int64_t b = 0; b < blocks; ++b) H += partH[size_t(b)], g += partg[size_t(b)];
  H = H.template selfadjointView<Eigen::Upper>();
}

// T o Delta_p: the increment about c applied first (forward composition).
template <int D>
AffineMap<D> compose(const AffineMap<D>& T, AlignmentModel model, const Eigen::VectorXd& p, const Point<D>& c) {
  const Matrix<D> L = increment_matrix<D>(model, p);
  AffineMap<D> delta;
  delta.matrix = L;
  delta.translation = c - L * c + p.head(D);
  return T.after(delta);
}

template <int D>
double corner_distance(const AffineMap<D>& a, const AffineMap<D>& b, const WorldBox<D>& box) {
  double d = 0;
  for (const Point<D>& x : corners<D>(box)) d = std::max(d, (a.apply(x) - b.apply(x)).norm());
  return d;
}

// The level of smoothing sigma: R's voxels inside the box at the stride, and S cut out around
// where the maps in `maps` take the box (with room for the motion), smoothed, and its gradient.
template <int D>
bool make_level(const Image<D>& fixed, const Image<D>& moving, const WorldBox<D>& box, const Point<D>& c,
                const std::vector<AffineMap<D>>& maps, double sigma, Level<D>& lv, int& stride) {
  const auto box_corners = corners<D>(box);
  const double pad = 3.0 * sigma + 2.0 * fixed.spacing().maxCoeff();
  GridIndex<D> lo, hi;
  if (!voxel_range<D>(fixed.grid(), {box_corners.begin(), box_corners.end()}, pad, lo, hi)) return false;
  const Image<D> r = gaussian_blur<D>(crop_voxels<D>(fixed, lo, hi), sigma);
  GridIndex<D> step;
  stride = 1;
  for (int a = 0; a < D; ++a) step[a] = std::max(1, int(std::floor(sigma / r.spacing()[a] + 0.5))), stride = std::max(stride, step[a]);
  lv.z.clear(), lv.r.clear();
  for (int64_t l = 0; l < r.num_voxels(); ++l) {
    const GridIndex<D> idx = r.grid().index(l);
    bool on = true;
    for (int a = 0; a < D; ++a) on = on && (idx[a] + lo[a]) % step[a] == 0;
    if (!on) continue;
    const Point<D> x = r.grid().to_world(r.grid().to_physical(idx));
    bool inside = true;
    for (int a = 0; a < D; ++a) inside = inside && x[a] >= box.lo[a] - 1e-9 && x[a] <= box.hi[a] + 1e-9;
    if (!inside) continue;
    lv.z.push_back(x - c);
    lv.r.push_back(r[l]);
  }
  if (lv.z.empty()) return false;
  double sum = 0;
  for (double v : lv.r) sum += v;
  lv.r_mean = sum / double(lv.r.size());
  lv.r_ss = 0;
  for (double v : lv.r) lv.r_ss += (v - lv.r_mean) * (v - lv.r_mean);
  // S around the images of the box under the maps, with 15% of the box's diagonal for the
  // level's motion (beyond it S is border-replicated: a level moving further is rare and the
  // next level cuts S out again about where it went)
  std::vector<Point<D>> where;
  for (const AffineMap<D>& T : maps)
    for (const Point<D>& x : box_corners) where.push_back(T.apply(x));
  const double motion = 0.15 * (box.hi - box.lo).norm();
  lv.full = moving.grid();
  if (!voxel_range<D>(moving.grid(), where, motion + 3.0 * sigma + 2.0 * moving.spacing().maxCoeff(), lo, hi)) {
    // the box maps outside the moving image: a one-voxel image at its nearest corner (overlap 0)
    voxel_range<D>(moving.grid(), {moving.grid().to_world(moving.grid().origin)}, 0.0, lo, hi);
  }
  lv.moving = gaussian_blur<D>(crop_voxels<D>(moving, lo, hi), sigma);
  lv.grad = gradient<D>(lv.moving);
  return true;
}

// Levenberg-Marquardt on one level from T (whose fit is `fit`): the pose block damped by lambda
// times its diagonal (Marquardt 1963); a step is taken only when it raises the score, keeps
// min_overlap of the start's overlap and keeps the orientation. T and fit end at the last step
// taken; returns the number of steps taken.
template <int D>
int levenberg_marquardt(const Level<D>& lv, const Point<D>& c, AlignmentModel model, const WorldBox<D>& box,
                        const ImageAlignmentOptions& options, double start_overlap, AffineMap<D>& T, Fit& fit) {
  const int np = parameter_count<D>(model);
  int iterations = 0;
  double lambda = 1e-3;
  Eigen::MatrixXd H;
  Eigen::VectorXd g;
  bool fresh = false;
  for (int it = 0; it < options.iterations && fit.finite && fit.score() > 0; ++it) {
    if (!fresh) normal_equations<D>(lv, T, c, model, fit, H, g), fresh = true;
    Eigen::MatrixXd Hd = H;
    for (int j = 0; j < np; ++j) Hd(j, j) += lambda * std::max(H(j, j), 1e-12);
    const Eigen::VectorXd step = Hd.ldlt().solve(g);
    const Eigen::VectorXd p = step.head(np);
    if (!p.allFinite()) break;
    const AffineMap<D> candidate = compose<D>(T, model, p, c);
    const Fit next = evaluate<D>(lv, candidate, c);
    const double moved = corner_distance<D>(candidate, T, box);
    if (next.finite && next.score() > fit.score() && next.overlap >= options.min_overlap * start_overlap &&
        candidate.matrix.determinant() > 0) {
      T = candidate, fit = next, fresh = false;
      ++iterations;
      lambda = std::max(lambda * 0.1, 1e-9);
      if (moved < options.tolerance) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e8 || moved < options.tolerance) break;
    }
  }
  return iterations;
}

}  // namespace

template <int D>
ImageAlignmentResult<D> align_images(const Image<D>& fixed, const Image<D>& moving, const WorldBox<D>& region,
                                     const AffineMap<D>& initial, const ImageAlignmentOptions& options) {
  try {
    validate_options(options);
  } catch (const OptionError& e) {
    throw std::invalid_argument("align_images: option \"" + e.key + "\" " + e.message);
  }
  if (fixed.empty() || moving.empty()) throw std::invalid_argument("align_images: an empty image");
  ImageAlignmentResult<D> result;
  result.transform = initial;
  WorldBox<D> box = region;
  box.lo.array() -= options.margin, box.hi.array() += options.margin;
  const Point<D> c = 0.5 * (box.lo + box.hi);
  const AlignmentModel model = options.model;

  AffineMap<D> T = initial;
  double start_overlap = -1;
  for (size_t k = 0; k < options.levels.size(); ++k) {
    AlignmentLevel info;
    info.sigma = options.levels[k];
    Level<D> lv;
    if (!make_level<D>(fixed, moving, box, c, {initial, T}, info.sigma, lv, info.stride)) {
      result.warning = "the region lies outside the reference image: the start is kept";
      result.transform = initial;
      return result;
    }
    info.samples = int64_t(lv.z.size());
    Fit fit = evaluate<D>(lv, T, c);
    if (start_overlap < 0) {
      start_overlap = evaluate<D>(lv, initial, c).overlap;
      if (start_overlap == 0) {
        result.warning = "the region maps entirely outside the moving image: the start is kept";
        return result;
      }
      if (!(lv.r_ss > 0)) {
        result.warning = "the reference image is constant within the region: the start is kept";
        return result;
      }
    }
    info.ncc_start = fit.ncc;
    info.iterations = levenberg_marquardt<D>(lv, c, model, box, options, start_overlap, T, fit);
    info.ncc_end = fit.ncc;
    result.iterations += info.iterations;
    result.levels.push_back(info);
    if (k + 1 == options.levels.size()) {
      // the guard, on the finest level: never worse than the start by the metric
      const Fit start = evaluate<D>(lv, initial, c);
      result.ncc_before = start.ncc;
      // ... and within the scale bound (options.max_scale) along every axis, relative to the
      // start: the singular values of T's linear part after the start's inverse (all equal for a
      // similarity; an affine may also not stretch or squash one direction beyond the bound).
      const Eigen::Matrix<double, D, 1> stretch =
          Eigen::JacobiSVD<Matrix<D>>(T.matrix * initial.matrix.inverse()).singularValues();
      const double largest = stretch.maxCoeff(), smallest = stretch.minCoeff();
      const double scale = largest * smallest > 1 ? largest : smallest;  // the one farther from 1
      const bool scale_ok = options.max_scale == 0 || (stretch.allFinite() && largest <= options.max_scale &&
                                                       smallest >= 1 / options.max_scale);
      if (fit.finite && fit.score() >= start.score() && scale_ok) {
        result.transform = T, result.ncc_after = fit.ncc, result.overlap = fit.overlap;
      } else {
        result.transform = initial, result.ncc_after = start.ncc, result.overlap = start.overlap;
        if (!scale_ok) {
          char why[200];
          std::snprintf(why, sizeof why,
                        "the alignment's scale %.3g is outside [1/%g, %g] of the start's (max_scale): the start is kept",
                        scale, options.max_scale, options.max_scale);
          result.warning = why;
        } else {
          result.warning = "the alignment did not improve the NCC: the start is kept";
        }
      }
    }
  }
  return result;
}

template ImageAlignmentResult<2> align_images<2>(const Image<2>&, const Image<2>&, const WorldBox<2>&, const AffineMap<2>&,
                                                 const ImageAlignmentOptions&);
template ImageAlignmentResult<3> align_images<3>(const Image<3>&, const Image<3>&, const WorldBox<3>&, const AffineMap<3>&,
                                                 const ImageAlignmentOptions&);

namespace {

// The world centroid of the voxels brighter than the image's mean: the object (a head, a body)
// against its background in any units (MR near 0, CT's air at -1000); none if no voxel is.
template <int D>
std::optional<Point<D>> foreground_centroid(const Image<D>& image) {
  double total = 0;
  for (int64_t l = 0; l < image.num_voxels(); ++l) total += image[l];
  const double mean = total / double(image.num_voxels());
  const Moments<D> m = region_moments<D>(image, [mean](float v) { return double(v) > mean; });
  if (!(m.measure > 0)) return std::nullopt;
  return m.centroid;
}

// The world box of an image's voxel centres (its corners', for an oblique grid).
template <int D>
WorldBox<D> image_box(const Image<D>& image) {
  const Grid<D>& g = image.grid();
  WorldBox<D> box;
  for (int corner = 0; corner < (1 << D); ++corner) {
    GridIndex<D> idx;
    for (int a = 0; a < D; ++a) idx[a] = (corner >> a & 1) ? g.size[a] - 1 : 0;
    const Point<D> x = g.to_world(g.to_physical(idx));
    if (corner == 0) box.lo = box.hi = x;
    box.lo = box.lo.cwiseMin(x), box.hi = box.hi.cwiseMax(x);
  }
  return box;
}

// The image block-averaged to voxels of about `size` mm (as fine as it is where it is finer), and
// to at most about kWholeImageVoxels voxels whatever `size` (a small template's scaled levels on
// a fine scan): the whole-image alignment costs a bounded amount.
constexpr double kWholeImageVoxels = 2e6;
template <int D>
Image<D> coarsened(const Image<D>& image, double size) {
  const int least = std::max(1, int(std::ceil(std::pow(double(image.num_voxels()) / kWholeImageVoxels, 1.0 / D))));
  GridIndex<D> f;
  bool any = false;
  for (int a = 0; a < D; ++a)
    f[a] = std::max(least, int(std::floor(size / image.spacing()[a]))), any = any || f[a] > 1;
  return any ? block_average<D>(image, f) : image;
}

}  // namespace

template <int D>
WholeImageAlignment<D> align_whole_images(const Image<D>& fixed, const Image<D>& moving, const AffineMap<D>& initial,
                                          const ImageAlignmentOptions& options) {
  WholeImageAlignment<D> out;
  out.fit.transform = initial;
  if (fixed.empty() || moving.empty()) throw std::invalid_argument("align_whole_images: an empty image");
  double finest = std::numeric_limits<double>::infinity();
  for (double s : options.levels) finest = std::min(finest, s);
  const Image<D> f = coarsened<D>(fixed, 0.5 * finest), m = coarsened<D>(moving, 0.5 * finest);
  // the centroids of the coarsened images: the same objects, at a fraction of the voxels
  const auto fixed_centroid = foreground_centroid<D>(f), moving_centroid = foreground_centroid<D>(m);
  if (!fixed_centroid || !moving_centroid) return out;
  out.centred = true;
  AffineMap<D> start = initial;
  out.centroid_shift = *moving_centroid - initial.apply(*fixed_centroid);
  start.translation += out.centroid_shift;
  ImageAlignmentOptions whole = options;
  whole.margin = 0.0;
  out.fit = align_images<D>(f, m, image_box<D>(f), start, whole);
  return out;
}

template WholeImageAlignment<2> align_whole_images<2>(const Image<2>&, const Image<2>&, const AffineMap<2>&,
                                                      const ImageAlignmentOptions&);
template WholeImageAlignment<3> align_whole_images<3>(const Image<3>&, const Image<3>&, const AffineMap<3>&,
                                                      const ImageAlignmentOptions&);

}  // namespace dsnake
