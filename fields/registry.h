// The external fields that an experiment file can name in "field": {"type": ..., ...}.
#pragma once

#include "framework/external_field.h"
#include "framework/registry.h"

namespace dsnake {

// Built on first use; one line per field in registry.cpp. D = 2 or 3.
template <int D>
const Registry<ExternalField<D>>& field_registry();

}  // namespace dsnake
