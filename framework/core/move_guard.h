// MoveGuard<D>: a check on the snake iteration's moves (§3.1) before they are made, such as a
// non-self-intersection constraint (framework/guard/collision_guard.h; after MIRTK's deformable surface
// model, whose constraint shortens or cancels a node's move that would make the surface cross
// itself). The phase driver owns at most one; SnakeStep calls it once per iteration, with the
// snake still at q(t) and the averaged positions q(t+1), before the positions are replaced.
#pragma once

#include "framework/core/shape.h"

#include <cstdint>
#include <string>

namespace dsnake {

// What a guard did, summed over its calls.
struct MoveGuardReport {
  int64_t shortened = 0;  // vertices whose move was shortened (but not cancelled)
  int64_t refused = 0;    // vertices whose move was cancelled (the vertex stayed at q(t))
  int64_t checks = 0;     // pair tests made (facet against facet, at the proposed positions)

  MoveGuardReport& operator+=(const MoveGuardReport& r) {
    shortened += r.shortened, refused += r.refused, checks += r.checks;
    return *this;
  }
};

template <int D>
class MoveGuard {
 public:
  virtual ~MoveGuard() = default;
  virtual std::string type() const = 0;
  // snake: at its current positions q(t); proposed: q(t+1), one finite point per vertex.
  // Moves proposed[v] back towards q(t)_v (anywhere on the segment, q(t)_v included) where the
  // move would break the guard's rule; leaves every other entry as it is. Must give the same
  // result whatever the thread count.
  virtual MoveGuardReport guard(const Snake<D>& snake, PointList<D>& proposed) = 0;
};

}  // namespace dsnake
