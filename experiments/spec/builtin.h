// Built-in experiments that need no input file: the default job of `dsnake run` and the
// end-to-end tests. Their text is an ordinary experiment file.
#pragma once

#include <string>
#include <vector>

namespace dsnake {

// The JSON text of a built-in experiment; throws InputError for an unknown name.
std::string builtin_experiment_text(const std::string& name);
std::vector<std::string> builtin_experiment_names();

}  // namespace dsnake
