// Measures of a triangle (a, b, c) in 3D, in physical units: its normal, area and angles, and
// comparison keys that avoid trigonometry; what the remeshing stages (§5) and the mesh-edit
// kernel (framework/mesh/edit_mesh.h) judge an edit by (normals turning, smallest angles).
#pragma once

#include "framework/core/types.h"

#include <Eigen/Geometry>
#include <cmath>

namespace dsnake {

// Cosine of the angle between two vectors given unnormalised (0 if one is zero): one square
// root, for comparisons of triangle normals taken as raw cross products.
inline double cos_between(const Point<3>& u, const Point<3>& v) {
  const double lengths2 = u.squaredNorm() * v.squaredNorm();
  return lengths2 > 0 ? u.dot(v) / std::sqrt(lengths2) : 0.0;
}
// (b - a) x (c - a): the triangle's normal times its doubled area.
inline Point<3> area_normal(const Point<3>& a, const Point<3>& b, const Point<3>& c) { return (b - a).cross(c - a); }
// Unit normal of triangle (a, b, c) (zero if degenerate) and its doubled area.
Point<3> triangle_normal(const Point<3>& a, const Point<3>& b, const Point<3>& c);
double triangle_area(const Point<3>& a, const Point<3>& b, const Point<3>& c);
// Smallest interior angle of a triangle, radians (0 if degenerate).
double min_angle(const Point<3>& a, const Point<3>& b, const Point<3>& c);
// A key that increases with the smallest interior angle, for comparisons only: -cos of it
// (-1 if degenerate), with no trigonometry; compare it with angle_key(threshold in radians).
// (Inline, with the vertex opposite the shortest edge chosen by selects rather than if/else: it
// runs once per triangle of every candidate edit, on data whose shortest edge is unpredictable.)
inline double min_angle_key(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const Point<3> ab = b - a, bc = c - b, ca = a - c;
  const double lab = ab.squaredNorm(), lbc = bc.squaredNorm(), lca = ca.squaredNorm();
  // At a (opposite bc), at b (opposite ca), at c (opposite ab).
  const double dot_a = -ab.dot(ca), dot_b = -bc.dot(ab), dot_c = -ca.dot(bc);
  const bool at_a = lbc <= lab && lbc <= lca, at_b = !at_a && lca <= lab;
  const double dot = at_a ? dot_a : (at_b ? dot_b : dot_c);
  const double lengths2 = at_a ? lab * lca : (at_b ? lbc * lab : lca * lbc);
  return lengths2 > 0 ? -dot / std::sqrt(lengths2) : -1.0;
}
inline double angle_key(double radians) { return -std::cos(radians); }
// Interior angle at vertex a of triangle (a, b, c), radians.
double angle_at(const Point<3>& a, const Point<3>& b, const Point<3>& c);

}  // namespace dsnake
