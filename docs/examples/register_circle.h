// docs/development.md's example of the registration library (registration/registration.h): a
// circle template, placed on an image, registered to the round object under it by D-Snake's
// three forces (Levi & Gotsman, §3.1, §6): the internal membrane, the external force of a GVF
// field (§2) and the ASAP-MLS deformation (§4.3), in one phase. No experiment file, no output.
#pragma once

#include "registration/registration.h"

namespace dsnake {

// circle: the template (its rest shape, mm); placed: where it starts on `image`, one position
// per template vertex (the image's frame, mm). The problem: internal + external (GVF) + ASAP-MLS,
// one phase of at most 400 iterations.
RegistrationProblem<2> circle_problem(const Template<2>& circle, const PointList<2>& placed, const Image<2>& image);
// register_template(circle_problem(circle, placed, image)).
RegistrationResult<2> register_circle(const Template<2>& circle, const PointList<2>& placed, const Image<2>& image);

}  // namespace dsnake
