// libFuzzer target: the sweep-file reader ("base", "grid", "methods", levels and seeds) and
// its expansion into runs; building every run as an experiment (validate) is left to the
// experiment-file target, which reads the same sections.
#include "tests/fuzz/fuzz_support.h"

#include "experiments/sweep/sweep.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dsnake;
  const std::string path = fuzz::write_input(data, size, "sweep.json");
  fuzz::expect_input_errors_only([&] { load_sweep(path, /*validate=*/false); });
  return 0;
}
