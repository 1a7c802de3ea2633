// The registration as one library call: a template placed on an image is moved by the weighted
// energies of Levi & Gotsman's D-Snake through its phases (§3, §6), each phase minimised by the
// snake iteration of §3.1 or by global Ceres solves. register_template() computes the external
// field on the region around the placed template (fields/region.h) and the smooth potential of
// the global view when one is asked for, binds the energies, guards the snake iteration against
// self-intersection (framework/guard/collision_guard.h), watches for divergence, runs the phases and
// reports what happened. No files and no JSON: the experiment runner (experiments/output/runner.h)
// builds a RegistrationProblem from an experiment file and writes files from the result, as
// MIRTK's deform-mesh configures its DeformableSurfaceModel.
#pragma once

#include "fields/region.h"
#include "fields/smooth_potential.h"
#include "framework/core/external_field.h"
#include "framework/core/options.h"
#include "framework/core/phase_driver.h"
#include "framework/global/global_problem.h"
#include "framework/guard/collision_guard.h"

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace dsnake {

// How a phase moves the snake: the snake iteration of §3.1 or one global Ceres solve.
enum class SolverKind { kSnake, kGlobal };
template <>
struct EnumNames<SolverKind> {
  static constexpr std::array<std::pair<SolverKind, const char*>, 2> table{
      {{SolverKind::kSnake, "snake"}, {SolverKind::kGlobal, "global"}}};
};

// What a registration needs, already assembled. Positions are in the image's frame
// (framework/core/image.h), mm. The template and the images are not owned: they must outlive the
// call; the field, the energies and the phases are handed over.
template <int D>
struct RegistrationProblem {
  const Template<D>* tmpl = nullptr;  // reference shape, connectivity, ids (and landmarks)
  PointList<D> initial;               // the placed template: one position per template vertex
  const Image<D>* image = nullptr;    // the image the template is registered to
  // An image in which the template at its rest positions lies on its object (an atlas), for the
  // energies that need one (Energy::needs_reference_image); null: none.
  const Image<D>* reference_image = nullptr;
  // The external field, not yet computed: it is computed here, on field_region's voxels.
  std::unique_ptr<ExternalField<D>> field;
  FieldRegionOptions field_region;
  // The smooth potential of the external term's global view (fields/smooth_potential.h), built on
  // the field's voxels; what the global solve's external term minimises.
  std::optional<PotentialOptions> potential;
  // The terms E = sum_e w_e E_e, in the order of result.term_names; every vertex must be governed
  // by one of them (framework/core/phase_driver.h).
  std::vector<WeightedEnergy<D>> energies;
  std::vector<Phase<D>> phases;  // run in order; at least one
  SolverKind solver = SolverKind::kSnake;
  GlobalSolverOptions global;             // solver kGlobal: Ceres' options
  CollisionGuardOptions collision_guard;  // solver kSnake: the check on every move
  Watchdog watchdog = Watchdog::off();    // when a run stops as diverged
  // The file the problem was read from ("": none): a field's own checks on the image throw an
  // InputError that knows the key but not the file; it is rethrown naming this one.
  std::string source;
};

// The distances an energy reports (Energy::reported_distances), mm: the landmark springs' (energies/
// landmarks.h), each landmark's distance to its point.
struct ReportedDistances {
  int energy = 0;  // the energy's index in RegistrationProblem::energies
  std::map<std::string, double> initial_mm;  // at the placed template
  std::map<std::string, double> final_mm;    // at the end of the run
};

// How strong the field's force is (framework/core/force_strength.h): |F| in the field's units,
// its largest over the field's voxels and its median at the snake's vertices at the start and
// the end, so that a caller can see whether the image's edges reach the template at all.
struct ForceMagnitudes {
  double max = 0;
  double median_start = 0;
  double median_end = 0;  // NaN for a diverged snake with non-finite positions
};

struct RegistrationTimings {
  double field_s = 0;      // computing the external field
  double potential_s = 0;  // building the global view's potential (0 without one)
  double evolve_s = 0;     // binding and running the phases
};

template <int D>
struct RegistrationResult {
  // The snake at the end: after a divergence, the last positions that passed the watchdog.
  Snake<D> snake;
  int initial_vertices = 0;  // the placed template's vertex count (before any remeshing)
  EvolveSummary summary;     // iterations, status and per-phase reports
  // One unique name per energy, in the problem's order: its type, with "_<index>" appended when
  // two energies share a type ("internal", "asap_mls_2"); the columns of an energy trace.
  std::vector<std::string> term_names;
  // w_e E_e per energy, in term_names' order, at the placed template before the first iteration
  // (with the energies' own weights, as the first phase has them unless it sets its own).
  std::vector<double> start_energy_terms;
  VoxelBox<D> field_region;  // the voxels the field (and the potential) was computed on
  ForceMagnitudes force;
  bool guarded = false;  // the collision guard checked the snake iteration's moves (solver kSnake, enabled)
  // Solver kGlobal: per phase run, Ceres' summary of each solve (empty for the snake iteration).
  std::vector<std::vector<GlobalSolveSummary>> global_solves;
  std::vector<ReportedDistances> landmarks;  // one per energy that reports distances (the landmark springs), in order
  RegistrationTimings timings;
};

// Progress messages for a person watching ("computing the gvf field on the image"); the
// iterations report through observers.
using RegistrationProgress = std::function<void(const std::string& message)>;

// Registers problem.tmpl, placed at problem.initial, to problem.image. The observers hear every
// iteration, remesh and phase end (framework/core/phase_driver.h), in the order given. Numerical
// trouble is not an exception: a run that diverges ends with summary.status kDiverged. Throws
// InputError when the field refuses the image (a VFC radius larger than the image).
template <int D>
RegistrationResult<D> register_template(RegistrationProblem<D> problem,
                                        const std::vector<EvolverObserver<D>*>& observers = {},
                                        const RegistrationProgress& progress = {});

}  // namespace dsnake
