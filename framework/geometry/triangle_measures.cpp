// Triangle measures; see triangle_measures.h.
#include "framework/geometry/triangle_measures.h"

#include <cmath>

namespace dsnake {

Point<3> triangle_normal(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const Point<3> n = (b - a).cross(c - a);
  const double len = n.norm();
  return len > 0 ? Point<3>(n / len) : Point<3>(Point<3>::Zero());
}

double triangle_area(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  return 0.5 * (b - a).cross(c - a).norm();
}

double angle_at(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const Point<3> u = b - a, v = c - a;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

// The smallest angle is the one opposite the shortest edge (law of sines): one atan2, not three
// (the same value as the smallest of the three, up to ties within rounding).
double min_angle(const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const double ab = (b - a).squaredNorm(), bc = (c - b).squaredNorm(), ca = (a - c).squaredNorm();
  if (bc <= ab && bc <= ca) return angle_at(a, b, c);
  if (ca <= ab) return angle_at(b, c, a);
  return angle_at(c, a, b);
}

}  // namespace dsnake
