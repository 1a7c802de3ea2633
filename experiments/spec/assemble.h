// Builds the objects of an experiment from its read sections (experiments/spec/experiment_spec.h):
// renders or reads the image and applies the corruptions, builds and places the template, sets
// the ground truth (a phantom's own, then files), builds the field, the energies and the phases.
// Problems that need the built objects (landmark ids beyond the template, an energy without a
// least-squares form in a global solve, a neighbourhood larger than the template) are
// InputErrors naming the file and the JSON path, as at reading.
#pragma once

#include "experiments/spec/experiment_spec.h"

namespace dsnake {

template <int D>
Experiment<D> assemble(const ExperimentSpec<D>& spec);

}  // namespace dsnake
