// libFuzzer target: `--set key.path=value` overrides. The input is up to eight lines,
// each one override, applied to the built-in 2D and 3D experiments; the result is read as an
// experiment file (every section), in the dimension the overrides leave it.
#include "tests/fuzz/fuzz_support.h"

#include "experiments/spec/experiment.h"
#include "experiments/spec/experiment_spec.h"

#include <algorithm>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake;
  std::vector<std::string> overrides;
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (size_t begin = 0; begin <= text.size() && overrides.size() < 8;) {
    const size_t end = std::min(text.find('\n', begin), text.size());
    overrides.push_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  for (const char* name : {"default", "ellipsoid"})
    fuzz::expect_input_errors_only([&] {
      const ExperimentFile file = builtin_experiment(name, overrides);
      if (file.dimension == 2) read_experiment_spec<2>(file);
      else read_experiment_spec<3>(file);
    });
  return 0;
}
