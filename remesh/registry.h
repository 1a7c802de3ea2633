// The remesher registry: every remeshing stage (§5), built by name from its JSON object.
#pragma once

#include "framework/core/registry.h"
#include "framework/core/remesher.h"

namespace dsnake {

template <int D>
const Registry<Remesher<D>>& remesher_registry();

}  // namespace dsnake
