// libFuzzer target: the experiment-file reader, as `dsnake validate` reads a file: the JSON
// text, then every section (experiment_spec.cpp), in the dimension the file declares.
#include "tests/fuzz/fuzz_support.h"

#include "experiments/spec/experiment.h"
#include "experiments/spec/experiment_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake;
  const std::string path = fuzz::write_input(data, size, "experiment.json");
  fuzz::expect_input_errors_only([&] {
    const ExperimentFile file = load_experiment_file(path);
    if (file.dimension == 2) read_experiment_spec<2>(file);
    else read_experiment_spec<3>(file);
  });
  return 0;
}
