#include "docs/examples/register_circle.h"

#include "energies/asap_mls.h"
#include "energies/external.h"
#include "energies/internal.h"
#include "fields/gvf.h"

namespace dsnake {

RegistrationProblem<2> circle_problem(const Template<2>& circle, const PointList<2>& placed, const Image<2>& image) {
  RegistrationProblem<2> problem;
  problem.tmpl = &circle;
  problem.initial = placed;
  problem.image = &image;
  problem.field = std::make_unique<GvfField<2>>();  // edge map sigma 1 mm, mu 0.2
  problem.energies.push_back({1.0, std::make_unique<InternalEnergy<2>>(InternalOptions{.alpha = 0.5})});
  problem.energies.push_back(
      {1.0, std::make_unique<ExternalEnergy<2>>(ExternalOptions{.tau = 1.0, .normalize = ForceNormalization::kMax})});
  problem.energies.push_back({0.5, std::make_unique<AsapMlsEnergy<2>>()});
  Phase<2>& fit = problem.phases.emplace_back();
  fit.iterations = 400;
  fit.tolerance = 1e-2;  // mm: stop when no vertex moves farther in one iteration
  return problem;
}

RegistrationResult<2> register_circle(const Template<2>& circle, const PointList<2>& placed, const Image<2>& image) {
  return register_template(circle_problem(circle, placed, image));
}

}  // namespace dsnake
