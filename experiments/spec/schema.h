// The experiment file's contract, generated from the code that reads it, so that it cannot
// drift: the JSON Schema (draft 2020-12) of experiment and sweep files, printed by
// `dsnake schema` for editors and validators, and the key tables of docs/experiment-file.md,
// printed by `dsnake schema --markdown`. Every key comes from the visit() of the options struct
// that reads it: the plug-in registries', the phantom families' (experiments/phantoms/phantoms.h)
// and the sections' (experiments/spec/experiment_spec.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace dsnake {

// The schema: an experiment file (required "dimension") or a sweep file (required "base").
nlohmann::ordered_json experiment_schema();

// The generated part of docs/experiment-file.md: one key table per section and plug-in.
std::string experiment_reference_markdown();

}  // namespace dsnake
