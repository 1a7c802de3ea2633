// Moments and closed-form similarities for pre-alignment; see alignment.h.
#include "framework/core/alignment.h"

#include "framework/core/errors.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <array>
#include <cmath>

namespace dsnake {

namespace {

template <int D>
using Matrix = Eigen::Matrix<double, D, D>;

// Raw moments about a reference point: M0 = int 1, M1 = int w, M2 = int w w^T (w = x - ref).
template <int D>
struct RawMoments {
  double m0 = 0.0;
  Point<D> m1 = Point<D>::Zero();
  Matrix<D> m2 = Matrix<D>::Zero();

  // Adds the signed simplex (ref, ref + w_1, ..., ref + w_D): its measure m = det[w] / D!, its
  // first moment m s / (D + 1) and its second m (sum_k w_k w_k^T + s s^T) / ((D + 1)(D + 2)),
  // s = sum_k w_k (the moments of a simplex with one vertex at the origin).
  void add_simplex(const std::array<Point<D>, D>& w) {
    Matrix<D> edges;
    for (int k = 0; k < D; ++k) edges.col(k) = w[k];
    const double m = edges.determinant() / (D == 2 ? 2.0 : 6.0);
    Point<D> s = Point<D>::Zero();
    Matrix<D> outer = Matrix<D>::Zero();
    for (int k = 0; k < D; ++k) s += w[k], outer.noalias() += w[k] * w[k].transpose();
    m0 += m;
    m1 += m * s / (D + 1);
    m2.noalias() += m / ((D + 1) * (D + 2)) * (outer + s * s.transpose());
  }
  // The moments about the centroid, the reference point added back; the signs of an oriented
  // boundary cancel in the ratios.
  Moments<D> central(const Point<D>& ref) const {
    Moments<D> out;
    if (m0 == 0.0) return out;
    const Point<D> c = m1 / m0;
    out.measure = std::abs(m0);
    out.centroid = ref + c;
    out.covariance = m2 / m0 - c * c.transpose();
    return out;
  }
};

// The proper orthonormal eigenvectors of a covariance (columns, by increasing eigenvalue).
template <int D>
void principal_axes(const Matrix<D>& covariance, Point<D>& eigenvalues, Matrix<D>& axes) {
  const Eigen::SelfAdjointEigenSolver<Matrix<D>> solver(covariance);
  eigenvalues = solver.eigenvalues();
  axes = solver.eigenvectors();
  if (axes.determinant() < 0) axes.col(D - 1) *= -1.0;
}

// Whether eigenvalues k and k + 1 (increasing) are too close to tell their axes apart.
template <int D>
bool degenerate_gap(const Point<D>& eigenvalues, int k, double tolerance) {
  return eigenvalues[k + 1] - eigenvalues[k] <= tolerance * std::abs(eigenvalues[D - 1]);
}

// Of the proper rotations F S E^T (S a diagonal of signs with det +1) that take the axes E onto
// the axes F, the one with the largest trace (closest to the identity).
template <int D>
Matrix<D> nearest_axis_rotation(const Matrix<D>& e, const Matrix<D>& f) {
  Matrix<D> best = Matrix<D>::Identity();
  double best_trace = -INFINITY;
  for (int signs = 0; signs < (1 << D); ++signs) {
    Point<D> s;
    for (int k = 0; k < D; ++k) s[k] = (signs >> k) & 1 ? -1.0 : 1.0;
    if (s.prod() < 0) continue;
    const Matrix<D> r = f * s.asDiagonal() * e.transpose();
    if (r.trace() > best_trace) best_trace = r.trace(), best = r;
  }
  return best;
}

// Centres the points: returns the mean, a[i] -= mean.
template <int D>
Point<D> centre(PointList<D>& a) {
  Point<D> mean = Point<D>::Zero();
  for (const auto& x : a) mean += x;
  if (!a.empty()) mean /= double(a.size());
  for (auto& x : a) x -= mean;
  return mean;
}

// The singular values of the centred points as a D x n matrix (their spread along each axis).
template <int D>
Point<D> spread(PointList<D> a) {
  centre<D>(a);
  Eigen::Matrix<double, D, Eigen::Dynamic> m(D, a.size());
  for (size_t i = 0; i < a.size(); ++i) m.col(i) = a[i];
  return Eigen::JacobiSVD<Eigen::Matrix<double, D, Eigen::Dynamic>>(m).singularValues();
}

}  // namespace

template <int D>
Moments<D> enclosed_moments(const PointList<D>& p, const Connectivity& connectivity) {
  RawMoments<D> raw;
  if (p.empty()) return {};
  Point<D> ref = Point<D>::Zero();
  for (const auto& x : p) ref += x;
  ref /= double(p.size());
  if constexpr (D == 2) {
    for (size_t i = 0; i < p.size(); ++i) raw.add_simplex({p[i] - ref, p[(i + 1) % p.size()] - ref});
  } else {
    for (const auto& t : connectivity.triangles()) raw.add_simplex({p[t[0]] - ref, p[t[1]] - ref, p[t[2]] - ref});
  }
  return raw.central(ref);
}

// Two passes (count and mean, then the covariance about the mean) in the grid's frame, then the
// frame's rotation to world.
template <int D>
Moments<D> region_moments(const Image<D>& image, const std::function<bool(float)>& inside) {
  const Grid<D>& g = image.grid();
  // voxel l's index kept as an odometer (x fastest) rather than divided out of l at every voxel
  auto next = [&g](GridIndex<D>& idx) {
    for (int a = 0; a < D && ++idx[a] == g.size[a]; ++a) idx[a] = 0;
  };
  int64_t count = 0;
  Point<D> sum = Point<D>::Zero();
  GridIndex<D> idx = GridIndex<D>::Zero();
  for (int64_t l = 0; l < image.num_voxels(); ++l, next(idx))
    if (inside(image[l])) ++count, sum += idx.template cast<double>().cwiseProduct(g.spacing);
  Moments<D> out;
  if (count == 0) return out;
  const Point<D> mean = sum / double(count);
  Matrix<D> c = Matrix<D>::Zero();
  idx.setZero();
  for (int64_t l = 0; l < image.num_voxels(); ++l, next(idx))
    if (inside(image[l])) {
      const Point<D> d = idx.template cast<double>().cwiseProduct(g.spacing) - mean;
      c.noalias() += d * d.transpose();
    }
  c /= double(count);
  c.diagonal() += g.spacing.cwiseProduct(g.spacing) / 12.0;  // each voxel is a box, not a point
  out.measure = double(count) * g.spacing.prod();
  out.centroid = g.to_world(g.origin + mean);
  out.covariance = g.direction * c * g.direction.transpose();
  return out;
}

template <int D>
Similarity<D> align_moments(const Moments<D>& from, const Moments<D>& to, double isotropy_tolerance, int* axes_matched) {
  DSNAKE_ASSERT(from.measure > 0 && to.measure > 0, "both shapes have a positive measure");
  Point<D> lf, lt;
  Matrix<D> e, f;
  principal_axes<D>(from.covariance, lf, e);
  principal_axes<D>(to.covariance, lt, f);
  std::array<bool, D - 1> degenerate{};
  int count = 0;
  for (int k = 0; k + 1 < D; ++k)
    count += degenerate[k] = degenerate_gap<D>(lf, k, isotropy_tolerance) || degenerate_gap<D>(lt, k, isotropy_tolerance);
  Similarity<D> s;
  s.scale = std::pow(to.measure / from.measure, 1.0 / D);
  int matched = D;
  if (count == D - 1) {
    matched = 0;  // near-isotropic: keep the orientation
  } else if (count > 0) {  // 3D, one gap: match the distinct axis (0 or 2) by the smallest rotation
    const int j = degenerate[0] ? 2 : 0;
    Point<D> a = e.col(j), b = f.col(j);
    if (a.dot(b) < 0) b = -b;
    if constexpr (D == 3) s.rotation = Eigen::Quaterniond::FromTwoVectors(a, b).toRotationMatrix();
    matched = 1;
  } else {
    s.rotation = nearest_axis_rotation<D>(e, f);
  }
  s.translation = to.centroid - s.scale * (s.rotation * from.centroid);
  if (axes_matched) *axes_matched = matched;
  return s;
}

// Minimise E(s, R, t) = sum_i |s R a_i + t - b_i|^2. Setting dE/dt = 0 gives t = b* - s R a*
// (a*, b* the means); with A_i = a_i - a*, B_i = b_i - b*,
//   E = s^2 sum |A_i|^2 - 2 s trace(R^T H) + sum |B_i|^2,  H = sum_i B_i A_i^T.
// For any s > 0 the best R maximises trace(R^T H). With H = U Sigma V^T, trace(R^T H) =
// trace(Sigma Z) for the orthogonal Z = V^T R^T U, largest at Z = diag(1, ..., 1, d) with
// d = sign det(U V^T) (d = -1 would otherwise need a reflection: flipping the smallest singular
// direction costs least). So R = U Z V^T and dE/ds = 0 gives s = trace(Sigma Z) / sum |A_i|^2.
template <int D>
Similarity<D> fit_similarity(const PointList<D>& a, const PointList<D>& b, bool with_scale) {
  DSNAKE_ASSERT(a.size() == b.size() && !a.empty(), "one target per point");
  PointList<D> ac = a, bc = b;
  const Point<D> am = centre<D>(ac), bm = centre<D>(bc);
  Matrix<D> h = Matrix<D>::Zero();
  double spread_a = 0.0;
  for (size_t i = 0; i < a.size(); ++i) h.noalias() += bc[i] * ac[i].transpose(), spread_a += ac[i].squaredNorm();
  const Eigen::JacobiSVD<Matrix<D>> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Point<D> z = Point<D>::Ones();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) z[D - 1] = -1.0;
  Similarity<D> s;
  s.rotation = svd.matrixU() * z.asDiagonal() * svd.matrixV().transpose();
  s.scale = with_scale && spread_a > 0 ? svd.singularValues().dot(z) / spread_a : 1.0;
  s.translation = bm - s.scale * (s.rotation * am);
  return s;
}

template <int D>
std::string point_pairs_problem(const PointList<D>& a, const PointList<D>& b) {
  const size_t needed = D == 2 ? 2 : 3;
  if (a.size() < needed)
    return "needs at least " + std::to_string(needed) + " point pairs, found " + std::to_string(a.size());
  for (const PointList<D>* points : {&a, &b}) {
    const Point<D> sv = spread<D>(*points);
    const char* which = points == &a ? "the template's landmarks" : "the points";
    if (sv[0] <= 1e-9) return std::string(which) + " all coincide";
    if (D == 3 && sv[1] <= 1e-3 * sv[0]) return std::string(which) + " lie on one line (the rotation about it is undetermined)";
  }
  return "";
}

template Moments<2> enclosed_moments<2>(const PointList<2>&, const Connectivity&);
template Moments<3> enclosed_moments<3>(const PointList<3>&, const Connectivity&);
template Moments<2> region_moments<2>(const Image<2>&, const std::function<bool(float)>&);
template Moments<3> region_moments<3>(const Image<3>&, const std::function<bool(float)>&);
template Similarity<2> align_moments<2>(const Moments<2>&, const Moments<2>&, double, int*);
template Similarity<3> align_moments<3>(const Moments<3>&, const Moments<3>&, double, int*);
template Similarity<2> fit_similarity<2>(const PointList<2>&, const PointList<2>&, bool);
template Similarity<3> fit_similarity<3>(const PointList<3>&, const PointList<3>&, bool);
template std::string point_pairs_problem<2>(const PointList<2>&, const PointList<2>&);
template std::string point_pairs_problem<3>(const PointList<3>&, const PointList<3>&);

}  // namespace dsnake
