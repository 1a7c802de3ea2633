// MLS neighbourhoods and weights (eq. (2)) and similarity / rotation fits (Appendix); see
// mls_weights.h. Schaefer, McPhail, Warren, "Image deformation using moving least squares"
// (SIGGRAPH 2006); Umeyama, "Least-squares estimation of transformation parameters between two
// point patterns" (PAMI 1991) for the reflection-safe rotation.
#include "energies/mls_weights.h"

#include "framework/core/errors.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>

namespace dsnake {

namespace {

// Template vertex ids within `rings` edges of j (j excluded), breadth first, in discovery order.
std::vector<int> ring_neighbors(const Connectivity& c, int j, int rings, std::vector<int>& mark, int stamp) {
  std::vector<int> found, frontier{j};
  mark[j] = stamp;
  for (int r = 0; r < rings && !frontier.empty(); ++r) {
    std::vector<int> next;
    for (int v : frontier)
      for (int w : c.neighbors(v))
        if (mark[w] != stamp) {
          mark[w] = stamp;
          next.push_back(w);
          found.push_back(w);
        }
    frontier.swap(next);
  }
  return found;
}

}  // namespace

template <int D>
int effective_rings(const NeighborhoodSpec& spec, int n) {
  if (spec.rings_at_vertices <= 0) return spec.rings;
  const double share = std::pow(double(n) / spec.rings_at_vertices, 1.0 / (D - 1));
  return std::max(1, int(std::lround(spec.rings * share)));
}

// Eq. (2) over the chosen neighbourhood; O(n^2) for kAll and kNearest (built once per template, §7).
template <int D>
MlsNeighborhoods build_neighborhoods(const Template<D>& tmpl, const NeighborhoodSpec& spec) {
  const int n = tmpl.num_vertices();
  const PointList<D>& p = tmpl.positions;
  Point<D> lo = p.empty() ? Point<D>::Zero() : p[0], hi = lo;
  for (const auto& x : p) { lo = lo.cwiseMin(x); hi = hi.cwiseMax(x); }
  const double coincident = 1e-12 * std::max((hi - lo).norm(), 1e-300);
  MlsNeighborhoods nb;
  std::vector<int> mark(n, -1), candidates;
  const int rings = effective_rings<D>(spec, n);
  std::vector<double> dist(n);
  for (int j = 0; j < n; ++j) {
    candidates.clear();
    if (spec.kind == NeighborhoodKind::kRings) {
      DSNAKE_ASSERT(tmpl.connectivity.num_vertices() == n, "ring neighbourhoods need the template connectivity");
      candidates = ring_neighbors(tmpl.connectivity, j, rings, mark, j);
    } else {
      for (int i = 0; i < n; ++i) {
        dist[i] = (p[i] - p[j]).squaredNorm();
        if (i != j) candidates.push_back(i);
      }
      if (spec.kind == NeighborhoodKind::kNearest && spec.k < int(candidates.size())) {
        // ties broken by id, so the result does not depend on the sort's implementation
        std::partial_sort(candidates.begin(), candidates.begin() + spec.k, candidates.end(),
                          [&](int a, int b) { return dist[a] < dist[b] || (dist[a] == dist[b] && a < b); });
        candidates.resize(spec.k);
      }
      std::sort(candidates.begin(), candidates.end());
    }
    const size_t start = nb.index.size();
    double total = 0.0;
    for (int i : candidates) {
      const double d = (p[i] - p[j]).norm();
      if (d <= coincident) continue;  // infinite weight: left out (degenerate fallback)
      const double w = spec.weights == MlsWeighting::kUniform ? 1.0 : std::pow(d, -2.0 * spec.falloff);
      nb.index.push_back(i);
      nb.weight.push_back(w);
      total += w;
    }
    for (size_t k = start; k < nb.weight.size(); ++k) nb.weight[k] /= total;
    nb.offsets.push_back(int(nb.index.size()));
  }
  return nb;
}

// 2D: M = [[s, -t], [t, s]] / spread with s = sum w a.b, t = sum w a x b: a similarity for any
// data, never a reflection (Schaefer et al. 2006, eq. for similarity deformations).
template <>
Eigen::Matrix2d best_similarity<2>(const Eigen::Matrix2d& cross, double spread) {
  if (!(spread > 1e-300)) return Eigen::Matrix2d::Zero();
  const double s = cross.trace(), t = cross(1, 0) - cross(0, 1);
  Eigen::Matrix2d m;
  m << s, -t, t, s;
  return m / spread;
}

namespace {

// The proper rotation R maximising trace(R^T cross) and t = trace(R^T cross) (Umeyama's sign
// fix: R = U diag(1, 1, d) V^T). Fast path: V from the closed-form eigen-decomposition of
// cross^T cross, u_k = cross v_k / s_k (k = 1, 2), and the third columns u1 x u2, v1 x v2, which
// makes both frames right-handed, so R = U V^T is a rotation and the sign fix is automatic. Rank < 2
// (collinear or coincident data, s2 <= 1e-6 s1) falls back to Eigen's JacobiSVD.
Eigen::Matrix3d rotation_3d_eigen(const Eigen::Matrix3d& cross, double& t) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cross.transpose() * cross);  // eigenvalues ascending
  const Eigen::Vector3d lambda = eig.eigenvalues();
  const double s1 = std::sqrt(std::max(lambda[2], 0.0)), s2 = std::sqrt(std::max(lambda[1], 0.0));
  if (s1 > 0 && s2 > 1e-6 * s1 && eig.info() == Eigen::Success) {
    const Eigen::Vector3d v1 = eig.eigenvectors().col(2), v2 = eig.eigenvectors().col(1);
    const Eigen::Vector3d u1 = (cross * v1).normalized();
    Eigen::Vector3d u2 = cross * v2;
    u2 = (u2 - u2.dot(u1) * u1).normalized();
    const Eigen::Vector3d u3 = u1.cross(u2), v3 = v1.cross(v2);
    const Eigen::Matrix3d r = u1 * v1.transpose() + u2 * v2.transpose() + u3 * v3.transpose();
    t = (r.transpose() * cross).trace();
    if (r.allFinite()) return r;
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  const double d = (u * v.transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Vector3d s = svd.singularValues();
  t = s[0] + s[1] + d * s[2];
  return u.col(0) * v.col(0).transpose() + u.col(1) * v.col(1).transpose() + d * u.col(2) * v.col(2).transpose();
}

// The same rotation by Horn's quaternion method ("Closed-form solution of absolute orientation
// using unit quaternions", JOSA A 1987): trace(R(q)^T cross) = q^T N q for a symmetric traceless
// 4x4 N built from cross, so R's quaternion is N's top eigenvector. The top eigenvalue is the
// largest root of det(N - l I) = l^4 + c2 l^2 + c1 l + c0, found by Newton's method from an upper
// bound (Theobald's QCP, Acta Cryst. A 2005), and the eigenvector is a column of adj(N - l I).
// No trigonometry: about a third of the cost of the eigen-decomposition above. The top root is
// separated from the next by 2 (s2 + d s3); when that gap is below 1e-3 |cross| (rank < 2, or a
// reflection with s2 ~ s3) the adjugate is too inaccurate and the eigen path decides instead.
Eigen::Matrix3d rotation_3d(const Eigen::Matrix3d& cross, double& t) {
  // S = cross^T (Horn's S_ab = sum a_a b_b for data a -> b with cross = sum b a^T).
  const double sxx = cross(0, 0), sxy = cross(1, 0), sxz = cross(2, 0);
  const double syx = cross(0, 1), syy = cross(1, 1), syz = cross(2, 1);
  const double szx = cross(0, 2), szy = cross(1, 2), szz = cross(2, 2);
  Eigen::Matrix4d n;
  n << sxx + syy + szz, syz - szy, szx - sxz, sxy - syx,  //
      syz - szy, sxx - syy - szz, sxy + syx, szx + sxz,    //
      szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy,   //
      sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz;
  const double frob2 = cross.squaredNorm();
  if (!(frob2 > 1e-300) || !std::isfinite(frob2)) return rotation_3d_eigen(cross, t);
  const double c2 = -2.0 * frob2, c1 = -8.0 * cross.determinant(), c0 = n.determinant();
  // Newton from sqrt(3) |cross| >= s1 + s2 + s3 >= the top root: monotone from above.
  double l = std::sqrt(3.0 * frob2);
  for (int it = 0; it < 60; ++it) {
    const double l2 = l * l;
    const double p = (l2 + c2) * l2 + c1 * l + c0, dp = (4.0 * l2 + 2.0 * c2) * l + c1;
    if (!(dp > 0)) break;
    const double step = p / dp;
    l -= step;
    if (std::abs(step) <= 1e-15 * l) break;
  }
  // adj(N - l I) = prod_{k != top} (l_k - l) q q^T: its largest diagonal entry picks the column.
  Eigen::Matrix4d a = n;
  a.diagonal().array() -= l;
  // det of a without row `skip_row` and column `skip_col`: the cofactors up to sign
  auto minor = [&a](int skip_row, int skip_col) {
    int r[3], c[3], kr = 0, kc = 0;
    for (int x = 0; x < 4; ++x) {
      if (x != skip_row) r[kr++] = x;
      if (x != skip_col) c[kc++] = x;
    }
    return a(r[0], c[0]) * (a(r[1], c[1]) * a(r[2], c[2]) - a(r[1], c[2]) * a(r[2], c[1])) -
           a(r[0], c[1]) * (a(r[1], c[0]) * a(r[2], c[2]) - a(r[1], c[2]) * a(r[2], c[0])) +
           a(r[0], c[2]) * (a(r[1], c[0]) * a(r[2], c[1]) - a(r[1], c[1]) * a(r[2], c[0]));
  };
  Eigen::Vector4d diagonal;
  for (int j = 0; j < 4; ++j) diagonal[j] = minor(j, j);
  int col = 0;
  const double best = diagonal.cwiseAbs().maxCoeff(&col);
  const double scale = std::sqrt(frob2);
  if (!(best > 1e-3 * scale * scale * scale)) return rotation_3d_eigen(cross, t);
  Eigen::Vector4d adj_col;  // column `col` of the adjugate: C_{i,col} = (-1)^{i+col} M_{col,i}
  for (int i = 0; i < 4; ++i) adj_col[i] = i == col ? diagonal[col] : ((i + col) % 2 == 0 ? 1 : -1) * minor(col, i);
  const Eigen::Vector4d q = adj_col.normalized();
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  Eigen::Matrix3d r;
  r << w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y),  //
      2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x),      //
      2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z;
  if (!r.allFinite()) return rotation_3d_eigen(cross, t);
  t = (r.transpose() * cross).trace();
  return r;
}

}  // namespace

// 3D (Appendix): M = mu R with R the proper rotation maximising trace(R^T cross) and
// mu = trace(R^T cross) / spread >= 0 (cross = U S V^T: mu = (s1 + s2 + d s3) / spread).
template <>
Eigen::Matrix3d best_similarity<3>(const Eigen::Matrix3d& cross, double spread) {
  if (!(spread > 1e-300)) return Eigen::Matrix3d::Zero();
  double t = 0.0;
  const Eigen::Matrix3d r = rotation_3d(cross, t);
  return std::max(0.0, t / spread) * r;
}

template <>
Eigen::Matrix2d best_rotation<2>(const Eigen::Matrix2d& cross) {
  const double s = cross.trace(), t = cross(1, 0) - cross(0, 1), r = std::hypot(s, t);
  if (!(r > 1e-300)) return Eigen::Matrix2d::Identity();
  Eigen::Matrix2d m;
  m << s, -t, t, s;
  return m / r;
}

template <>
Eigen::Matrix3d best_rotation<3>(const Eigen::Matrix3d& cross) {
  if (!(cross.cwiseAbs().maxCoeff() > 1e-300)) return Eigen::Matrix3d::Identity();
  double t = 0.0;
  return rotation_3d(cross, t);
}

template int effective_rings<2>(const NeighborhoodSpec&, int);
template int effective_rings<3>(const NeighborhoodSpec&, int);
template MlsNeighborhoods build_neighborhoods<2>(const Template<2>&, const NeighborhoodSpec&);
template MlsNeighborhoods build_neighborhoods<3>(const Template<3>&, const NeighborhoodSpec&);

template <int D>
void map_template_vertices(const Snake<D>& snake, int n, std::vector<int>& vertex_of_id) {
  vertex_of_id.resize(n);
  for (int t = 0; t < n; ++t) {
    vertex_of_id[t] = snake.vertex_of_template_id(t);
    DSNAKE_ASSERT(vertex_of_id[t] >= 0, "every template vertex is on the snake");
  }
}

template void map_template_vertices<2>(const Snake<2>&, int, std::vector<int>&);
template void map_template_vertices<3>(const Snake<3>&, int, std::vector<int>&);

}  // namespace dsnake
