// How strong an external field's force is, globally and at a snake's vertices. The external
// energy's "normalize": "max" divides the force by the field's largest magnitude, so that its
// step tau is a distance in mm (D-Snake §3.1: q^ext = q + tau F); result.json's
// "external_force" reports the median at the template's vertices at the start and the end of a
// run, so that a user can see whether the image's edges reach the template at all.
#pragma once

#include "framework/core/external_field.h"
#include "framework/core/shape.h"

namespace dsnake {

// max over the field's voxels of |F| (the sampled vectors() of the field; 0 for an empty or
// all-zero field). Exact, so it does not depend on the thread count.
template <int D>
double max_force_magnitude(const ExternalField<D>& field);

// Median over the snake's vertices of |F(q_v, n_v)| (n_v the outward unit vertex normal, for
// fields that look at it); 0 for a snake without vertices. NaN positions give NaN.
template <int D>
double median_force_magnitude(const ExternalField<D>& field, const Snake<D>& snake);

}  // namespace dsnake
