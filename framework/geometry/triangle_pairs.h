// The pair tests of the surface's crossing checks, shared by the mesh-edit kernel's broad phase
// and its optimistic check (framework/mesh/edit_mesh.h) and by the collision guard
// (framework/guard/collision_guard.h): float box filters rounded outwards, and whether two
// triangles conflict given the vertices they share (§5: an edit, or a snake step, must not make
// the surface cross itself), with certificates of the radius within which a pair that shares a
// vertex or an edge cannot come to conflict. Inline: they run once per candidate pair.
#pragma once

#include "framework/core/types.h"
#include "framework/geometry/predicates.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>

namespace dsnake {

// A box in floats rounded outwards from a box in doubles: a filter only (boxes apart in floats
// are apart), half the memory of the doubles.
struct FloatBox {
  float lo[3], hi[3];
};

// x as a float at most / at least x (box filters that never reject a real overlap): moved
// outwards by 2^-20 relative (plus a tiny absolute term) before the conversion, whose
// rounding is at most 2^-24 relative. Cheaper than nextafter, and only a filter.
inline float float_down(double x) { return static_cast<float>(x - (std::abs(x) * 0x1p-20 + 1e-30)); }
inline float float_up(double x) { return static_cast<float>(x + (std::abs(x) * 0x1p-20 + 1e-30)); }

// [lo, hi] as a FloatBox that contains it.
inline FloatBox outward_box(const Point<3>& lo, const Point<3>& hi) {
  FloatBox b;
  for (int k = 0; k < 3; ++k) b.lo[k] = float_down(lo[k]), b.hi[k] = float_up(hi[k]);
  return b;
}

// Boxes entirely apart along some axis (without branches, which mispredict on such data).
inline bool boxes_apart(const FloatBox& a, const FloatBox& b) {
  return (a.lo[0] > b.hi[0]) | (a.lo[1] > b.hi[1]) | (a.lo[2] > b.hi[2]) | (b.lo[0] > a.hi[0]) |
         (b.lo[1] > a.hi[1]) | (b.lo[2] > a.hi[2]);
}

constexpr double kFoldCos = 0.990268;  // cos(8 degrees): closer than that across an edge is a fold

// Closed segment [p, q] against the closed triangle (a, b, c), Moller-Trumbore; a segment
// parallel to the triangle's plane counts as missing it (the coplanar case is left to the
// fold and normal checks of the edits). Two cheap rejections come first: disjoint boxes, and
// both ends strictly on one side of the plane (by a relative margin of 1e-9, far above
// rounding, so that the exact test could only have said "no" as well: t would be outside
// [0, 1] by more than 1e-9).
// tlo, thi: the triangle's bounding box (the caller has it).
inline bool segment_hits_triangle(const Point<3>& p, const Point<3>& q, const Point<3>& a, const Point<3>& b,
                                  const Point<3>& c, const Point<3>& tlo, const Point<3>& thi) {
  const double slack = 1e-9 * (thi - tlo).maxCoeff();
  if ((p.cwiseMax(q).array() < tlo.array() - slack).any() || (p.cwiseMin(q).array() > thi.array() + slack).any())
    return false;
  const Point<3> e1 = b - a, e2 = c - a;
  const Point<3> n = e1.cross(e2);
  const double dp = n.dot(p - a), dq = n.dot(q - a);
  if ((dp > 0 && dq > 0) || (dp < 0 && dq < 0)) {
    const double small = std::min(std::abs(dp), std::abs(dq)), large = std::max(std::abs(dp), std::abs(dq));
    if (small > 1e-9 * large) return false;
  }
  const Point<3> d = q - p;
  const Point<3> h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = d.norm() * e1.norm() * e2.norm();
  if (std::abs(det) <= 1e-12 * scale) return false;
  const double inv = 1.0 / det;
  const Point<3> s = p - a;
  const double u = inv * s.dot(h);
  if (u < -1e-12 || u > 1 + 1e-12) return false;
  const Point<3> qv = s.cross(e1);
  const double v = inv * d.dot(qv);
  if (v < -1e-12 || u + v > 1 + 1e-12) return false;
  const double t = inv * e2.dot(qv);
  return t >= -1e-12 && t <= 1 + 1e-12;
}

// true if the three points lie strictly on one side of the plane of triangle q, by a margin
// (1e-10 of |n|_1 |x - q0|_inf, which bounds |n . (x - q0)|) far above rounding: then the
// two triangles cannot meet, whatever the exact test would compute.
inline bool strictly_one_side(const std::array<Point<3>, 3>& p, const std::array<Point<3>, 3>& q) {
  const Point<3> n = (q[1] - q[0]).cross(q[2] - q[0]);
  const double n1 = n.lpNorm<1>();
  int above = 0, below = 0;
  for (const auto& x : p) {
    const Point<3> r = x - q[0];
    const double d = n.dot(r), margin = 1e-10 * n1 * r.lpNorm<Eigen::Infinity>();
    if (d > margin) ++above;
    else if (d < -margin) ++below;
  }
  return above == 3 || below == 3;
}

// Whether triangles A and B (vertex ids ta, tb, positions pa, pb) conflict, given the vertices
// they share: disjoint ones must not touch; with one shared vertex, neither opposite edge may
// pierce the other triangle; with a shared edge, they must not fold onto each other.
// loa, hia, lob, hib: the triangles' bounding boxes.
inline bool pair_conflicts(const Triangle& ta, const std::array<Point<3>, 3>& pa, const Point<3>& loa,
                           const Point<3>& hia, const Triangle& tb, const std::array<Point<3>, 3>& pb, const Point<3>& lob,
                           const Point<3>& hib) {
  int shared = 0, ia = -1, ib = -1;  // ia/ib: a shared corner's index in A/B
  int sa[3] = {0, 0, 0}, sb[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (ta[i] == tb[j]) { ++shared; sa[i] = 1; sb[j] = 1; ia = i; ib = j; }
  if (shared == 0) {
    if (strictly_one_side(pa, pb) || strictly_one_side(pb, pa)) return false;
    return triangles_intersect(pa, pb);
  }
  if (shared == 3) return true;  // a duplicate triangle
  if (shared == 1) {
    return segment_hits_triangle(pa[(ia + 1) % 3], pa[(ia + 2) % 3], pb[0], pb[1], pb[2], lob, hib) ||
           segment_hits_triangle(pb[(ib + 1) % 3], pb[(ib + 2) % 3], pa[0], pa[1], pa[2], loa, hia);
  }
  // Shared edge: the opening angle between the two half-planes must exceed 8 degrees.
  int oa = 0, ob = 0;
  while (sa[oa]) ++oa;
  while (sb[ob]) ++ob;
  const Point<3>& u = pa[(oa + 1) % 3];
  const Point<3> e = (pa[(oa + 2) % 3] - u).normalized();
  Point<3> xa = pa[oa] - u, xb = pb[ob] - u;
  xa -= xa.dot(e) * e;
  xb -= xb.dot(e) * e;
  // Most pairs open wide (a cosine <= 0, far from the fold): decided without the norms, as the
  // division below would decide them (norm() is the root of squaredNorm(), 0 only where it is 0).
  const double dot = xa.dot(xb);
  if (dot <= 0 && xa.squaredNorm() != 0 && xb.squaredNorm() != 0) return false;
  const double na = xa.norm(), nb = xb.norm();
  if (na == 0 || nb == 0) return true;
  return dot / (na * nb) > kFoldCos;
}

// How many corners triangles a and b share (0 to 3).
inline int shared_corners(const Triangle& a, const Triangle& b) {
  int shared = 0;
  for (int u : a) shared += (u == b[0]) + (u == b[1]) + (u == b[2]);
  return shared;
}

// A certificate for triangles A and B (vertex ids ta, tb, positions pa, pb) that share exactly
// one vertex v, the pairs a guard tests most (about three quarters of a mesh's adjacent
// pairs): a radius r such that, while each of their five vertices stays within r of its
// position here, the pair cannot conflict (pair_conflicts is false). 0: no certificate.
// Proof: take a plane through v with unit normal n, with A's other corners at heights
// n . (a - v) >= d_a > 0 and B's at n . (b - v) <= -d_b < 0. Moving each vertex by less than r
// changes each height by less than r, so A's opposite edge stays above d_a - r while B (the
// convex hull of v and its other corners) stays below r: they are apart while r <= d_a / 2.
// Likewise B's opposite edge and A while r <= d_b / 2. r = min(d_a, d_b) / 2 less a twentieth of
// the pair's longest edge, so that a pair within its certificate is apart by at least a tenth
// of that edge: far more than the exact test's tolerances (1e-12 in barycentric coordinates,
// near-misses count as hits) and its rounding could bridge. n: the plane between the directions
// from v to the midpoints of the opposite edges.
inline double shared_vertex_radius(const Triangle& ta, const std::array<Point<3>, 3>& pa, const Triangle& tb,
                                   const std::array<Point<3>, 3>& pb) {
  if (shared_corners(ta, tb) != 1) return 0;
  int ia = 0;
  while (ta[ia] != tb[0] && ta[ia] != tb[1] && ta[ia] != tb[2]) ++ia;
  const Point<3>& o = pa[ia];
  const Point<3> a1 = pa[(ia + 1) % 3] - o, a2 = pa[(ia + 2) % 3] - o;
  Point<3> b[2];
  for (int j = 0, k = 0; j < 3; ++j)
    if (tb[j] != ta[ia]) b[k++] = pb[j] - o;
  const Point<3> ma = 0.5 * (a1 + a2), mb = 0.5 * (b[0] + b[1]);
  const double la = ma.norm(), lb = mb.norm();
  if (!(la > 0) || !(lb > 0)) return 0;
  const Point<3> n = ma / la - mb / lb;
  const double nn = n.norm();
  if (!(nn > 1e-6)) return 0;
  const Point<3> u = n / nn;
  const double da = std::min(u.dot(a1), u.dot(a2)), db = std::min(-u.dot(b[0]), -u.dot(b[1]));
  const double longest = std::sqrt(std::max({a1.squaredNorm(), a2.squaredNorm(), (a2 - a1).squaredNorm(),
                                             b[0].squaredNorm(), b[1].squaredNorm(), (b[1] - b[0]).squaredNorm()}));
  const double r = 0.5 * std::min(da, db) - 0.05 * longest;
  return std::isfinite(r) && r > 0 ? r : 0;
}

// A certificate for triangles A and B (vertex ids ta, tb, positions pa, pb) that share exactly
// one edge u-w, the pairs a guard tests most once the others have certificates (85%
// of the lung's exact tests): a radius r such that, while each of their four vertices stays
// within r of its position here, the pair cannot fold (pair_conflicts is false). 0: none.
// Proof: with the edge vector e = w - u and the apexes a, b, the vectors n_a = e x (a - u) and
// n_b = e x (b - u) are L e^ x x_a and L e^ x x_b (x_a, x_b: the apexes' offsets normal to the
// edge, the vectors pair_conflicts measures the opening angle between), so the angle between
// n_a and n_b is the opening angle theta. Moving the vertices by less than r changes
// e x (a - u) by at most 2 r |a - u| + 2 r |e| + 4 r^2 =: Delta_a, which turns n_a by less than
// asin(Delta_a / |n_a|) (and leaves it non-zero) while Delta_a < |n_a|; likewise n_b. So theta
// stays above the fold angle (8 degrees) while both turns stay below half of theta less that
// angle less a margin of one degree, far above the test's rounding: r is the largest radius
// with Delta_x <= sin(that half) |n_x| for both apexes.
inline double shared_edge_radius(const Triangle& ta, const std::array<Point<3>, 3>& pa, const Triangle& tb,
                                 const std::array<Point<3>, 3>& pb) {
  if (shared_corners(ta, tb) != 2) return 0;
  int oa = 0, ob = 0;  // the corners off the shared edge
  while (ta[oa] == tb[0] || ta[oa] == tb[1] || ta[oa] == tb[2]) ++oa;
  while (tb[ob] == ta[0] || tb[ob] == ta[1] || tb[ob] == ta[2]) ++ob;
  const Point<3>& u = pa[(oa + 1) % 3];
  const Point<3> e = pa[(oa + 2) % 3] - u, xa = pa[oa] - u, xb = pb[ob] - u;
  const Point<3> na = e.cross(xa), nb = e.cross(xb);
  const double la = na.norm(), lb = nb.norm();
  if (!(la > 0) || !(lb > 0)) return 0;
  const double theta = std::atan2(na.cross(nb).norm(), na.dot(nb));
  constexpr double kFoldAngle = 0.13962634015954636;  // 8 degrees (kFoldCos)
  constexpr double kMargin = 0.017453292519943295;    // 1 degree
  const double half = 0.5 * (theta - kFoldAngle - kMargin);
  if (!(half > 0)) return 0;
  const double s = std::sin(std::min(half, 1.5));
  // The largest r with 4 r^2 + 2 S r <= s |n|, S = |x - u| + |e|.
  auto radius = [&](double span, double area2) { return (std::sqrt(span * span + 4 * s * area2) - span) / 4; };
  const double length = e.norm();
  const double r = std::min(radius(xa.norm() + length, la), radius(xb.norm() + length, lb));
  return std::isfinite(r) && r > 0 ? r : 0;
}

}  // namespace dsnake
