// Potential<D>: a smooth scalar potential P >= 0 on the image domain, sampled with its gradient
// at any physical point. The global solve's external term is E_ext = sum_v P(q_v) (Levi &
// Gotsman, §1); GVF, DDGVF and VFC are not gradients of a potential, so fields/smooth_potential.h
// builds one (edge, distance, or the least-squares integral of the field).
#pragma once

#include "framework/core/types.h"

#include <string>

namespace dsnake {

template <int D>
class Potential {
 public:
  virtual ~Potential() = default;
  // P(x); thread-safe.
  virtual double value(const Point<D>& x) const = 0;
  // P(x) and grad P(x), consistent with value() (the Ceres gradient checks compare them).
  virtual double value_and_gradient(const Point<D>& x, Point<D>& gradient) const = 0;
};

}  // namespace dsnake
