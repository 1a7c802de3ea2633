#include "registration/registration.h"

#include "framework/core/errors.h"
#include "framework/core/evolver.h"
#include "framework/core/force_strength.h"
#include "framework/core/image_filters.h"
#include "framework/global/global_solver.h"

#include <algorithm>
#include <chrono>

namespace dsnake {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Unique names for the energy terms: "internal", "external", "asap_mls_2", ...
template <int D>
std::vector<std::string> term_names(const std::vector<WeightedEnergy<D>>& energies) {
  std::vector<std::string> names;
  for (size_t i = 0; i < energies.size(); ++i) {
    std::string n = energies[i].energy->type();
    if (std::count_if(energies.begin(), energies.end(), [&](const auto& e) { return e.energy->type() == n; }) > 1)
      n += "_" + std::to_string(i);
    names.push_back(n);
  }
  return names;
}

// The distances each energy reports (Energy::reported_distances: the landmark springs'), at the
// placed template and at the end.
// The placed template's snake is made only when an energy reports distances.
template <int D>
std::vector<ReportedDistances> reported_distances(const std::vector<WeightedEnergy<D>>& energies,
                                                  const RegistrationProblem<D>& problem, const Snake<D>& end) {
  std::vector<ReportedDistances> list;
  std::optional<Snake<D>> start;
  for (size_t e = 0; e < energies.size(); ++e) {
    auto final_mm = energies[e].energy->reported_distances(end);
    if (!final_mm) continue;
    if (!start) start = Snake<D>::from_template(*problem.tmpl, problem.initial);
    ReportedDistances d;
    d.energy = static_cast<int>(e);
    d.final_mm = std::move(*final_mm);
    d.initial_mm = *energies[e].energy->reported_distances(*start);
    list.push_back(std::move(d));
  }
  return list;
}

// Computes the field on `region` of the image and the external term's potential on the same
// voxels (it is built from the field or its image). The cropped copy is the field's to release
// (a volume less through the run) unless the potential reads it too (edge, distance); then it
// goes once that is built.
template <int D>
std::unique_ptr<SmoothPotential<D>> compute_field_and_potential(RegistrationProblem<D>& problem, const VoxelBox<D>& region,
                                                                const RegistrationProgress& progress,
                                                                RegistrationTimings& timings) {
  auto t = Clock::now();
  const bool whole = region.num_voxels() == problem.image->num_voxels();
  Image<D> cropped = whole ? Image<D>() : crop(*problem.image, region);
  const Image<D>& field_image = whole ? *problem.image : cropped;
  const bool potential_reads_image = problem.potential && problem.potential->type != PotentialType::kIntegrated;
  const bool field_takes_crop = !whole && !potential_reads_image;
  try {
    problem.field->check_grid(field_image.grid());
    if (progress)
      progress("computing the " + problem.field->type() + " field on " + (D == 2 ? "the image" : "the volume"));
    if (field_takes_crop)
      compute_releasing(*problem.field, std::move(cropped));
    else
      problem.field->compute(field_image);
  } catch (const InputError& e) {
    // A field's own checks on the image (a VFC radius larger than the image, an unstable explicit
    // step) know the key, not the file.
    if (!e.file().empty()) throw;
    throw InputError(problem.source, e.where(), e.message());
  }
  timings.field_s = seconds_since(t);
  if (!problem.potential) return nullptr;
  t = Clock::now();
  auto potential = make_potential<D>(*problem.potential, field_image, problem.field.get());
  timings.potential_s = seconds_since(t);
  return potential;
}

}  // namespace

template <int D>
RegistrationResult<D> register_template(RegistrationProblem<D> problem, const std::vector<EvolverObserver<D>*>& observers,
                                        const RegistrationProgress& progress) {
  DSNAKE_ASSERT(problem.tmpl && problem.image && problem.field, "a registration needs a template, an image and a field");
  DSNAKE_ASSERT(int(problem.initial.size()) == problem.tmpl->num_vertices(),
                "the placed template needs one position per template vertex");
  RegistrationResult<D> result;
  // The field on the region around the placed template (fields/region.h).
  result.field_region = region_of_interest(problem.image->grid(), problem.initial, problem.field_region);
  const std::unique_ptr<SmoothPotential<D>> potential =
      compute_field_and_potential(problem, result.field_region, progress, result.timings);
  result.snake = Snake<D>::from_template(*problem.tmpl, problem.initial);
  result.initial_vertices = result.snake.num_vertices();
  result.force.max = max_force_magnitude(*problem.field);
  result.force.median_start = median_force_magnitude(*problem.field, result.snake);
  // The energies sample the whole image (the polarity rule's noise floor is a median over all of
  // it, another number on the field's region alone), and share its smoothed copies: one blur per
  // sigma.
  SmoothedImageCache<D> smoothed_images;
  EnergyContext<D> context{problem.tmpl, problem.image, problem.field.get(), potential.get(), problem.reference_image,
                           &smoothed_images};
  const auto t = Clock::now();
  std::unique_ptr<Minimizer<D>> minimizer;
  GlobalSolve<D>* global = nullptr;
  if (problem.solver == SolverKind::kGlobal) {
    auto g = std::make_unique<GlobalSolve<D>>(problem.global);
    global = g.get();
    minimizer = std::move(g);
  } else {
    minimizer = std::make_unique<SnakeStep<D>>();
  }
  PhaseDriver<D> driver(context, std::move(problem.energies), std::move(minimizer));
  // The collision guard checks the snake iteration's moves; the global solve does not use one.
  result.guarded = problem.solver == SolverKind::kSnake && problem.collision_guard.enabled;
  if (result.guarded) driver.set_move_guard(std::make_unique<CollisionGuard<D>>(problem.collision_guard));
  driver.set_watchdog(problem.watchdog);
  result.term_names = term_names(driver.energies());
  result.start_energy_terms = driver.energy_terms(result.snake);
  for (EvolverObserver<D>* observer : observers) driver.add_observer(observer);
  result.summary = driver.run(result.snake, problem.phases);
  result.force.median_end = median_force_magnitude(*problem.field, result.snake);
  result.landmarks = reported_distances(driver.energies(), problem, result.snake);
  if (global) result.global_solves = global->solves();
  result.timings.evolve_s = seconds_since(t);
  return result;
}

template RegistrationResult<2> register_template<2>(RegistrationProblem<2>, const std::vector<EvolverObserver<2>*>&,
                                                    const RegistrationProgress&);
template RegistrationResult<3> register_template<3>(RegistrationProblem<3>, const std::vector<EvolverObserver<3>*>&,
                                                    const RegistrationProgress&);

}  // namespace dsnake
