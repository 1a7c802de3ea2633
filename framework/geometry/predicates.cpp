// Exact intersection predicates of segments and triangles; see predicates.h.
#include "framework/geometry/predicates.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace dsnake {

namespace {

// Twice the signed area of (a, b, c): positive when counter-clockwise.
double orient2d(const Point<2>& a, const Point<2>& b, const Point<2>& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

// Six times the signed volume of the tetrahedron (a, b, c, d).
double orient3d(const Point<3>& a, const Point<3>& b, const Point<3>& c, const Point<3>& d) {
  return (b - a).cross(c - a).dot(d - a);
}

// For p collinear with [a, b]: whether p lies within the segment's bounding box.
bool within_box(const Point<2>& a, const Point<2>& b, const Point<2>& p) {
  return p.x() >= std::min(a.x(), b.x()) && p.x() <= std::max(a.x(), b.x()) &&
         p.y() >= std::min(a.y(), b.y()) && p.y() <= std::max(a.y(), b.y());
}

// Whether p lies in the closed triangle (a, b, c) of the plane (either orientation).
bool point_in_triangle_2d(const Point<2>& p, const Point<2>& a, const Point<2>& b, const Point<2>& c) {
  const double s0 = orient2d(a, b, p), s1 = orient2d(b, c, p), s2 = orient2d(c, a, p);
  return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

// Segment [p, q] against the closed triangle (a, b, c), for a segment not lying in the
// triangle's plane (an in-plane segment returns false; the caller covers that case).
bool segment_crosses_triangle(const Point<3>& p, const Point<3>& q, const Point<3>& a,
                              const Point<3>& b, const Point<3>& c) {
  const double dp = orient3d(a, b, c, p), dq = orient3d(a, b, c, q);
  if ((dp > 0 && dq > 0) || (dp < 0 && dq < 0) || (dp == 0 && dq == 0)) return false;
  // The segment meets the plane; the meeting point is inside iff the line pq passes on the
  // same side of (or touches) all three edges.
  const double s0 = orient3d(p, q, a, b), s1 = orient3d(p, q, b, c), s2 = orient3d(p, q, c, a);
  return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

// Coplanar triangles: project onto the plane of the normal's dominant axis and test in 2D.
bool coplanar_triangles_intersect(const std::array<Point<3>, 3>& p, const std::array<Point<3>, 3>& q) {
  const Point<3> n = (p[1] - p[0]).cross(p[2] - p[0]).cwiseAbs();
  const int drop = n.x() >= n.y() && n.x() >= n.z() ? 0 : (n.y() >= n.z() ? 1 : 2);
  const int u = (drop + 1) % 3, v = (drop + 2) % 3;
  std::array<Point<2>, 3> a, b;
  for (int k = 0; k < 3; ++k) {
    a[k] = Point<2>(p[k][u], p[k][v]);
    b[k] = Point<2>(q[k][u], q[k][v]);
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (segments_intersect(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3])) return true;
  return point_in_triangle_2d(a[0], b[0], b[1], b[2]) || point_in_triangle_2d(b[0], a[0], a[1], a[2]);
}

}  // namespace

bool segments_intersect(const Point<2>& a, const Point<2>& b, const Point<2>& c, const Point<2>& d) {
  const double o1 = orient2d(a, b, c), o2 = orient2d(a, b, d);
  const double o3 = orient2d(c, d, a), o4 = orient2d(c, d, b);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0)))
    return true;  // proper crossing
  return (o1 == 0 && within_box(a, b, c)) || (o2 == 0 && within_box(a, b, d)) ||
         (o3 == 0 && within_box(c, d, a)) || (o4 == 0 && within_box(c, d, b));
}

// Each triangle is split by the other's plane or not; if they are not coplanar they meet iff
// an edge of one meets the other (the ends of their common segment lie on edges).
bool triangles_intersect(const std::array<Point<3>, 3>& p, const std::array<Point<3>, 3>& q) {
  std::array<double, 3> dq, dp;
  // orient3d is a product of three lengths: values within rounding of zero (relative to the
  // pair's extent cubed) are zero, so that coplanar triangles (a flat subdivided face) take the
  // coplanar test instead of giving false crossings.
  Point<3> lo = p[0], hi = p[0];
  for (int k = 0; k < 3; ++k) lo = lo.cwiseMin(p[k]).cwiseMin(q[k]), hi = hi.cwiseMax(p[k]).cwiseMax(q[k]);
  const double extent = (hi - lo).maxCoeff(), eps = 1e-12 * extent * extent * extent;
  for (int k = 0; k < 3; ++k) {
    dq[k] = orient3d(p[0], p[1], p[2], q[k]);
    dp[k] = orient3d(q[0], q[1], q[2], p[k]);
    if (std::abs(dq[k]) <= eps) dq[k] = 0;
    if (std::abs(dp[k]) <= eps) dp[k] = 0;
  }
  auto one_side = [](const std::array<double, 3>& s) {
    return (s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0);
  };
  if (one_side(dq) || one_side(dp)) return false;
  if (dq[0] == 0 && dq[1] == 0 && dq[2] == 0) return coplanar_triangles_intersect(p, q);
  for (int k = 0; k < 3; ++k) {
    if (segment_crosses_triangle(p[k], p[(k + 1) % 3], q[0], q[1], q[2])) return true;
    if (segment_crosses_triangle(q[k], q[(k + 1) % 3], p[0], p[1], p[2])) return true;
  }
  return false;
}

}  // namespace dsnake
