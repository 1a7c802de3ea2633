// The energies that an experiment file can name in "energies": [{"type": ..., ...}].
#pragma once

#include "framework/core/energy.h"
#include "framework/core/registry.h"

namespace dsnake {

// Built on first use; one line per energy in registry.cpp. D = 2 or 3.
template <int D>
const Registry<Energy<D>>& energy_registry();

}  // namespace dsnake
