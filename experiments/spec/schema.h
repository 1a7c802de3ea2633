// The experiment file's contract, generated from the code that reads it, so that it cannot
// drift: the JSON Schema (draft 2020-12) of experiment and sweep files, printed by
// `dsnake schema` for editors and validators, and the key tables of docs/experiment-file.md,
// printed by `dsnake schema --markdown`. Plug-in keys come from the registries (each options
// struct's visit()), phantom keys from recording what each phantom reads (json_reader.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace dsnake {

// The schema: an experiment file (required "dimension") or a sweep file (required "base").
nlohmann::ordered_json experiment_schema();

// The generated part of docs/experiment-file.md: one key table per section and plug-in.
std::string experiment_reference_markdown();

}  // namespace dsnake
