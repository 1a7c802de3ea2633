// The patch force; see patch.h. Normalised cross-correlation of atlas patches at the rest
// positions, and the Gauss-Newton (Lucas-Kanade) step that raises it (Baker & Matthews, IJCV 2004,
// §2; the contrast a projected out in closed form).
#include "energies/patch.h"

#include "energies/rest_positions.h"
#include "framework/core/alignment.h"
#include "framework/core/errors.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace dsnake {

namespace {

constexpr double kFlat = 1e-12;  // a patch whose centred norm^2 is below this has no appearance

int ipow(int b, int e) {
  int r = 1;
  for (int i = 0; i < e; ++i) r *= b;
  return r;
}

// Removes the mean and scales to unit norm; false (cleared) when flat.
bool centre_and_normalise(std::vector<double>& x) {
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= double(x.size());
  double norm2 = 0.0;
  for (double& v : x) {
    v -= mean;
    norm2 += v * v;
  }
  if (!(norm2 > kFlat)) {
    x.clear();
    return false;
  }
  const double s = 1.0 / std::sqrt(norm2);
  for (double& v : x) v *= s;
  return true;
}

// The centred second moments of a least-squares affine fit a_i -> b_i: A = sum (a_i - a)(a_i - a)^T
// and B = sum (b_i - b)(a_i - a)^T (a, b the means); the fit's linear part is B A^{-1}.
template <int D>
void centred_moments(const PointList<D>& a, const PointList<D>& b, Eigen::Matrix<double, D, D>& aa,
                     Eigen::Matrix<double, D, D>& ba) {
  const size_t n = a.size();
  Point<D> ca = Point<D>::Zero(), cb = Point<D>::Zero();
  for (size_t i = 0; i < n; ++i) ca += a[i], cb += b[i];
  ca /= double(n);
  cb /= double(n);
  aa.setZero();
  ba.setZero();
  for (size_t i = 0; i < n; ++i) {
    aa += (a[i] - ca) * (a[i] - ca).transpose();
    ba += (b[i] - cb) * (a[i] - ca).transpose();
  }
}

// Whether a linear map is usable for a patch: orientation-preserving and not far from conformal
// (singular values within a factor 4).
template <int D>
bool near_conformal(const Eigen::Matrix<double, D, D>& l) {
  if (!l.allFinite() || !(l.determinant() > 0)) return false;
  Eigen::JacobiSVD<Eigen::Matrix<double, D, D>> svd(l);
  const auto sv = svd.singularValues();
  return sv(D - 1) > 0 && sv(0) / sv(D - 1) < 4.0;
}

// The linear part of the least-squares affine map a_i -> b_i (centred), or of the similarity when
// the affine is singular, reflecting or far from conformal (an ill-posed fit of a flat template).
template <int D>
Eigen::Matrix<double, D, D> placement_linear_part(const PointList<D>& a, const PointList<D>& b) {
  using Mat = Eigen::Matrix<double, D, D>;
  if (a.size() <= size_t(D)) return Mat::Identity();
  Mat aa, ba;
  centred_moments<D>(a, b, aa, ba);
  Eigen::JacobiSVD<Mat> aa_svd(aa);
  if (aa_svd.singularValues()(D - 1) > 1e-9 * aa_svd.singularValues()(0)) {
    const Mat l = ba * aa.inverse();
    if (near_conformal<D>(l)) return l;
  }
  const Similarity<D> s = fit_similarity<D>(a, b, true);
  return s.scale * s.rotation;
}

// The sums of a patch comparison: the mean of the samples s[index(k)] and, with c_k = s[index(k)] -
// mean, es = sum e_k c_k and ss = sum c_k^2 (NCC = es / sqrt(ss) for a unit-norm, centred e).
struct Correlation {
  double mean = 0.0, es = 0.0, ss = 0.0;
};
template <class Index>
Correlation correlate(const std::vector<double>& e, const double* s, Index index) {
  const int count = static_cast<int>(e.size());
  Correlation r;
  for (int k = 0; k < count; ++k) r.mean += s[index(k)];
  r.mean /= count;
  for (int k = 0; k < count; ++k) {
    const double c = s[index(k)] - r.mean;
    r.es += e[k] * c;
    r.ss += c * c;
  }
  return r;
}

constexpr double kLocalMapRegularisation = 0.05;  // lambda, relative to the mean squared spread
constexpr double kRemapTolerance = 0.01;           // resample a patch when max |L_v - L_used| exceeds this
constexpr double kMappedPreSmoothing = 0.8;        // smoothing mapped: the atlas's own smoothing, times sigma

// Each vertex's neighbourhood for its local map: v, its one-ring, and every vertex reached from v
// along edges through vertices whose rest positions lie within `radius` of v's and whose rest
// normals lie within 90 degrees of v's (breadth-first, v first), as offsets + list. The normal
// test keeps the far side of a thin part (a gyrus, a fold: both sides within the radius) out of
// v's map: with it, the map would measure the part's thickness, and a snake that thickened it
// would see its atlas patches stretched to match, a change that feeds itself.
template <int D>
void neighbourhoods(const Snake<D>& snake, const PointList<D>& rest, double radius, std::vector<int>& offsets,
                    std::vector<int>& list) {
  const int n = snake.num_vertices();
  const Connectivity& c = snake.connectivity();
  const PointList<D> normals = vertex_normals<D>(rest, c);
  offsets.assign(1, 0);
  list.clear();
  std::vector<int> seen(n, -1);  // the vertex whose search last reached it
  const double r2 = radius * radius;
  for (int v = 0; v < n; ++v) {
    const size_t first = list.size();
    list.push_back(v);
    seen[v] = v;
    for (size_t i = first; i < list.size(); ++i)
      for (int u : c.neighbors(list[i]))
        if (seen[u] != v &&
            (i == first || ((rest[u] - rest[v]).squaredNorm() <= r2 && normals[u].dot(normals[v]) > 0))) {
          seen[u] = v;
          list.push_back(u);
        }
    offsets.push_back(static_cast<int>(list.size()));
  }
}

}  // namespace

template <int D>
Point<D> patch_offset(int k, int half) {
  Point<D> o;
  const int w = 2 * half + 1;
  for (int d = 0; d < D; ++d) {
    o(d) = double(k % w - half);
    k /= w;
  }
  return o;
}

template <int D>
PatchEnergy<D>::PatchEnergy(const PatchOptions& options) : options_(checked(options, kType)) {}

template <int D>
void PatchEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  DSNAKE_ASSERT(context.image != nullptr && context.tmpl != nullptr, "the patch energy samples the image");
  if (context.reference_image == nullptr)
    throw OptionError{"type", "the patch force needs an atlas image: template.reference_image"};
  const Image<D>& scan = image_.of(*context.image, options_.sigma, context.smoothed_images);
  const double atlas_sigma = options_.smoothing == PatchSmoothing::kMapped ? kMappedPreSmoothing * options_.sigma : options_.sigma;
  const Image<D>& ref = reference_.of(*context.reference_image, atlas_sigma, context.smoothed_images);
  h_ = options_.spacing > 0 ? options_.spacing : scan.grid().spacing.minCoeff();
  half_ = std::max(1, static_cast<int>(std::lround(options_.radius / h_)));
  count_ = ipow(2 * half_ + 1, D);
  // Inner point k (half-width K) -> its index in the outer lattice (half-width K + 1).
  outer_.resize(count_);
  for (int k = 0; k < count_; ++k) {
    int idx = 0, r = k, stride = 1;
    for (int d = 0; d < D; ++d) {
      idx += (r % (2 * half_ + 1) + 1) * stride;
      r /= 2 * half_ + 1;
      stride *= 2 * half_ + 3;
    }
    outer_[k] = idx;
  }

  const Template<D>& tmpl = *context.tmpl;
  const RestPositions<D> rest = rest_positions(tmpl, snake);
  const int n = snake.num_vertices();
  PointList<D> p(n), a, b;
  for (int v = 0; v < n; ++v) {
    p[v] = ref.grid().to_frame(rest.positions[v]);
    if (snake.is_deformation_vertex(v)) {
      a.push_back(p[v]);
      b.push_back(snake.positions()[v]);
    }
  }
  linear_ = placement_linear_part<D>(a, b);
  rest_frame_ = std::move(p);
  bound_at_ = snake.positions();
  if (options_.map_radius > 0) {
    neighbourhoods<D>(snake, rest_frame_, options_.map_radius, ring_offsets_, ring_);
    maps_.resize(n);
    for (int v = 0; v < n; ++v) maps_[v] = local_map(v, snake.positions());
  }
  expected_.clear();  // sampled on first use (set_up_expected): a term switched off in this phase costs nothing
  correlation_.assign(n, 0.0);
}

// L_v: the affine map of v's ring (v included, centred on their means) from the rest positions
// a_i to the current positions b_i, min sum |L (a_i - a) - (b_i - b)|^2 + lambda tr(A) / D |L - S|^2
// with A = sum (a_i - a)(a_i - a)^T and S the ring's similarity; S itself where the ring is too
// small, or the affine reflects or is far from conformal.
template <int D>
Eigen::Matrix<double, D, D> PatchEnergy<D>::local_map(int v, const PointList<D>& q) const {
  using Mat = Eigen::Matrix<double, D, D>;
  const int begin = ring_offsets_[v], end = ring_offsets_[v + 1], m = end - begin;
  if (m <= 1) return linear_;
  PointList<D> a(m), b(m);
  for (int i = 0; i < m; ++i) {
    a[i] = rest_frame_[ring_[begin + i]];
    b[i] = q[ring_[begin + i]];
  }
  const Similarity<D> sim = fit_similarity<D>(a, b, true);
  const Mat s = sim.scale * sim.rotation;
  Mat aa, ba;
  centred_moments<D>(a, b, aa, ba);
  const double lambda = kLocalMapRegularisation * aa.trace() / D;
  if (!(lambda > 0)) return linear_;
  const Mat l = (ba + lambda * s) * (aa + lambda * Mat::Identity()).inverse();
  if (near_conformal<D>(l)) return l;
  return s.allFinite() && sim.scale > 0 ? s : linear_;
}

// Vertex v's expected patch: the smoothed atlas at its rest position (reference frame) plus
// m^{-1} h k, mean removed, unit norm.
template <int D>
std::vector<double> PatchEnergy<D>::sample_expected(int v, const Eigen::Matrix<double, D, D>& m) const {
  using Mat = Eigen::Matrix<double, D, D>;
  const Image<D>& ref = reference_.image();
  const Mat back = m.inverse();
  // The quadrature of the smoothing left after the atlas's own (patch.h): nodes 0 and +-sqrt(3)
  // standard deviations along each eigenvector of sigma^2 m^-1 m^-T - (pre sigma)^2 I, weights
  // 2/3, 1/6, 1/6 (Gauss-Hermite, exact for polynomials up to degree 5 along each); one node of
  // weight 1 with `smoothing` image.
  constexpr int kMaxNodes = D == 2 ? 9 : 27;  // 3^D, on the stack: this runs at every resampling
  std::array<Point<D>, kMaxNodes> nodes;
  std::array<double, kMaxNodes> weights;
  nodes[0] = Point<D>::Zero();
  weights[0] = 1.0;
  int count = 1;
  const double sigma = options_.sigma;
  if (options_.smoothing == PatchSmoothing::kMapped && sigma > 0) {
    const double pre = kMappedPreSmoothing * sigma;
    const Eigen::SelfAdjointEigenSolver<Mat> rest(sigma * sigma * back * back.transpose() - pre * pre * Mat::Identity());
    for (int d = 0; d < D; ++d) {
      const double sd = std::sqrt(std::max(0.0, rest.eigenvalues()(d)));
      if (!(sd > 1e-9)) continue;
      const Point<D> axis = std::sqrt(3.0) * sd * rest.eigenvectors().col(d);
      for (int i = 0, n = count; i < n; ++i) {
        nodes[count] = nodes[i] + axis;
        nodes[count + 1] = nodes[i] - axis;
        weights[count] = weights[count + 1] = weights[i] / 6.0;
        weights[i] *= 2.0 / 3.0;
        count += 2;
      }
    }
  }
  std::vector<double> e(count_);
  for (int k = 0; k < count_; ++k) {
    const Point<D> x = rest_frame_[v] + back * (h_ * patch_offset<D>(k, half_));
    double sum = 0.0;
    for (int j = 0; j < count; ++j) sum += weights[j] * ref.sample(Point<D>(x + nodes[j]));
    e[k] = sign_ * sum;
  }
  if (!centre_and_normalise(e)) e.clear();
  return e;
}

template <int D>
void PatchEnergy<D>::set_up_expected() const {
  if (!expected_.empty() || rest_frame_.empty()) return;
  const int n = static_cast<int>(rest_frame_.size());
  expected_.assign(n, {});
  sign_ = 1;  // sampled positive, negated below where the contrast is negative
#pragma omp parallel for schedule(static) if (n >= 64)
  for (int v = 0; v < n; ++v) expected_[v] = sample_expected(v, patch_map(v));
  bool negative = options_.contrast == PatchContrast::kNegative;
  if (options_.contrast == PatchContrast::kAuto) {
    std::vector<double> ncc(n, 0.0);
#pragma omp parallel if (n >= 64)
    {
      std::vector<double> s(ipow(2 * half_ + 3, D));
#pragma omp for schedule(static)
      for (int v = 0; v < n; ++v) ncc[v] = match(v, bound_at_[v], nullptr, s.data());
    }
    double sum = 0.0;  // in vertex order: the same sign for any thread count
    for (double c : ncc) sum += c;
    negative = sum < 0;
  }
  if (negative) {
    sign_ = -1;
    for (auto& e : expected_)
      for (double& x : e) x = -x;
  }
}

template <int D>
double PatchEnergy<D>::match(int v, const Point<D>& x, Point<D>* move, double* s) const {
  if (move) *move = Point<D>::Zero();  // no evidence (a flat patch here or in the atlas): hold
  const std::vector<double>& e = expected_[v];
  if (e.empty()) return 0.0;
  const Image<D>& scan = image_.image();
  if (!move) {  // the NCC alone: the patch's own samples, no ring for the differences
    scan.sample_lattice(x, h_, half_, s);
    const Correlation c = correlate(e, s, [](int k) { return k; });
    return c.ss > kFlat ? c.es / std::sqrt(c.ss) : 0.0;
  }
  const int w = 2 * half_ + 3;  // the patch and one ring more, for the central differences
  scan.sample_lattice(x, h_, half_ + 1, s);
  int stride[D];
  stride[0] = 1;
  for (int d = 1; d < D; ++d) stride[d] = stride[d - 1] * w;
  const int* outer_index = outer_.data();
  auto outer = [outer_index](int k) { return outer_index[k]; };
  const Correlation c = correlate(e, s, outer);
  if (!(c.ss > kFlat)) return 0.0;
  const double mean = c.mean, es = c.es, ss = c.ss;
  const double ncc = es / std::sqrt(ss);
  Point<D> gmean = Point<D>::Zero();
  for (int k = 0; k < count_; ++k)
    for (int d = 0; d < D; ++d) gmean(d) += s[outer(k) + stride[d]] - s[outer(k) - stride[d]];
  gmean /= (2.0 * h_ * count_);
  // The contrast a (a s' ~ e). With the scan's gradients (forward): the least-squares fit of e on
  // s', whose residual e - a s' is orthogonal to s' (no pull towards where the scan's patch merely
  // has more energy). With the atlas patch's gradients: 1 / the fit of s' on e (es, as |e| = 1),
  // which noise in the scan leaves unbiased; the fit of e on s' takes the noise in its regressor
  // and shrinks a, and the step with it, by about NCC^2.
  const double a = options_.gradient == PatchGradient::kScan ? es / ss : (es > 0 ? 1.0 / es : 0.0);
  if (!(a > 0) || ncc < options_.min_correlation) return ncc;
  Eigen::Matrix<double, D, D> h = Eigen::Matrix<double, D, D>::Zero();
  Point<D> g = Point<D>::Zero();
  // The step's gradients (patch.h): the scan's times a (the atlas patch's scale), the atlas
  // patch's own, or their mean.
  const double ws = options_.gradient == PatchGradient::kAtlas  ? 0.0
                    : options_.gradient == PatchGradient::kBoth ? 0.5
                                                                : 1.0;
  const double we = 1.0 - ws;
  const int n1 = 2 * half_ + 1;
  int istride[D];
  istride[0] = 1;
  for (int d = 1; d < D; ++d) istride[d] = istride[d - 1] * n1;
  Point<D> emean = Point<D>::Zero();
  auto egrad = [&](int k) {  // central differences of e on the inner lattice, one-sided at its border
    Point<D> ge;
    int r = k;
    for (int d = 0; d < D; ++d) {
      const int c = r % n1;
      r /= n1;
      const int lo = c > 0 ? k - istride[d] : k, hi = c < n1 - 1 ? k + istride[d] : k;
      ge(d) = (e[hi] - e[lo]) / (h_ * ((c > 0) + (c < n1 - 1)));
    }
    return ge;
  };
  if (we > 0) {
    for (int k = 0; k < count_; ++k) emean += egrad(k);
    emean /= count_;
  }
  for (int k = 0; k < count_; ++k) {
    const int o = outer(k);
    Point<D> grad;
    for (int d = 0; d < D; ++d) grad(d) = (s[o + stride[d]] - s[o - stride[d]]) / (2.0 * h_);
    grad = ws * a * (grad - gmean);
    if (we > 0) grad += we * (egrad(k) - emean);
    const double r = e[k] - a * (s[o] - mean);
    h += grad * grad.transpose();
    g += grad * r;
  }
  const double lambda = options_.damping * h.trace() / D;
  h.diagonal().array() += lambda;
  if (!(h.trace() > 0)) return ncc;
  Point<D> delta = h.ldlt().solve(g);
  const double longest = options_.max_step > 0 ? options_.max_step : h_;
  const double len = delta.norm();
  if (!std::isfinite(len)) return ncc;
  if (len > longest) delta *= longest / len;
  *move = delta;
  return ncc;
}

template <int D>
void PatchEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  const int n = snake.num_vertices();
  DSNAKE_ASSERT(int(out.size()) == n && int(rest_frame_.size()) == n, "bind() before propose(), one entry per vertex");
  set_up_expected();
  const PointList<D>& q = snake.positions();
  const size_t stride = ipow(2 * half_ + 3, D);
  const double step = options_.step;
  const bool local = options_.map_radius > 0;
#pragma omp parallel if (n >= 64)
  {
    std::vector<double> scratch(stride);  // one per thread: each vertex is computed alone
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v) {
      if (local) {  // follow the snake's local stretch: refit L_v, resample where it changed
        const Eigen::Matrix<double, D, D> m = local_map(v, q);
        if ((m - maps_[v]).cwiseAbs().maxCoeff() > kRemapTolerance) {
          maps_[v] = m;
          expected_[v] = sample_expected(v, m);
        }
      }
      Point<D> delta;
      correlation_[v] = match(v, q[v], &delta, scratch.data());
      out[v] = q[v] + step * delta;
    }
  }
}

template <int D>
double PatchEnergy<D>::value(const Snake<D>& snake) const {
  const int n = snake.num_vertices();
  set_up_expected();
  if (int(expected_.size()) != n) return std::numeric_limits<double>::quiet_NaN();
  const size_t stride = ipow(2 * half_ + 3, D);
  std::vector<double> terms(n);
#pragma omp parallel if (n >= 64)
  {
    std::vector<double> s(stride);
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v) terms[v] = 1.0 - match(v, snake.positions()[v], nullptr, s.data());
  }
  double total = 0.0;  // summed in vertex order: the same bits for any thread count
  for (double t : terms) total += t;
  return total;
}

template Point<2> patch_offset<2>(int, int);
template Point<3> patch_offset<3>(int, int);
template class PatchEnergy<2>;
template class PatchEnergy<3>;

}  // namespace dsnake
