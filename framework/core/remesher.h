// Remesher<D>: changes a snake's vertices and connectivity (§5). Contract: every deformation
// vertex keeps its template id and its position, and is never collapsed or merged; the result
// is a closed polygon / closed manifold mesh. A remesher that changes vertices or connectivity
// goes through Snake::set_topology(), which bumps snake.topology_version(): that is how energies
// learn to rebind. One that only moves free vertices writes snake.positions() in place and
// leaves the version (and every energy's precomputation) as it is.
#pragma once

#include "framework/core/shape.h"

#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace dsnake {

template <int D> class Image;

template <int D>
struct RemeshContext {
  const Template<D>* tmpl = nullptr;
  const Image<D>* image = nullptr;  // voxel size, for thresholds "one voxel edge by default"
  int phase_iteration = 0;          // iteration within the phase, for threshold schedules (§6)
  int phase_iterations = 0;         // the phase's iteration budget
  // The vertex budget (the watchdog's max_vertices): a stage that adds vertices never makes the
  // snake larger than this; where it would, it stops adding (or, resampling, leaves the snake as
  // it was) and sets its report's over_budget, which stops the run as diverged.
  int max_vertices = std::numeric_limits<int>::max();
};

struct RemeshReport {
  std::string stage;
  int vertices_before = 0;
  int vertices_after = 0;
  int rejected_edits = 0;  // edits refused because they would break a guarantee
  bool over_budget = false;  // the stage stopped at the context's vertex budget
};

// The edge length a stage refines towards and the key that sets it (relative to the stage's
// object): the assembly estimates the vertices a phase will need from it (the placed
// template's perimeter / length in 2D, its area / (length^2 sqrt(3) / 2) in 3D).
struct RefinementLength {
  std::string key;
  double length = 0;  // physical units
};

template <int D>
class Remesher {
 public:
  virtual ~Remesher() = default;
  virtual std::string type() const = 0;
  virtual RemeshReport apply(Snake<D>& snake, const RemeshContext<D>& context) = 0;
  // The length this stage refines towards; none for a stage that never adds vertices (it only
  // moves, flips or removes them).
  virtual std::optional<RefinementLength> refinement_length() const { return std::nullopt; }
  // As apply(), with one report per stage for a remesher made of stages (remesh/pipeline.h).
  virtual std::vector<RemeshReport> apply_stages(Snake<D>& snake, const RemeshContext<D>& context) {
    return {apply(snake, context)};
  }
};

}  // namespace dsnake
