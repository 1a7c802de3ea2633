// Our explicit GVF against ITK 5.2's itk::GradientVectorFlowImageFilter on the same input: the
// gradient of the edge map of bench_fields' 230 x 300 x 80 ellipsoid (blur sigma = 1), mu = 0.2,
// 100 iterations, and ITK's own time step 1 / (2^D mu) (the filter overrides any other), which our
// solver is given too. Both sides include forming b = |grad f|^2 from grad f. After the timings it
// prints the ratio of the medians and the largest difference between the two fields, relative to
// the largest vector, so that the comparison is of the same computation.
// Built only when ITK is found (libinsighttoolkit5-dev); nothing else depends on it.
// Run: build/release/experiments/bench/bench_itk_gvf --benchmark_repetitions=1
#include "fields/edge_map.h"
#include "framework/numerics/grid_diffusion_solver.h"

#include "experiments/bench/bench_images.h"

#include <itkCovariantVector.h>
#include <itkGradientVectorFlowImageFilter.h>
#include <itkImage.h>
#include <itkLaplacianImageFilter.h>
#include <itkMultiThreaderBase.h>

#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

namespace dsnake {
namespace {

constexpr double kMu = 0.2;
constexpr int kIterations = 100;
constexpr double kItkTimeStep = 1.0 / (8 * kMu);  // ITK 5.2's GenerateData: 1 / (2^D noise level)

using Vector3f = itk::CovariantVector<float, 3>;
using VectorImage = itk::Image<Vector3f, 3>;

const EdgeMap<3>& edges() {
  static const EdgeMap<3> e = compute_edge_map(bench::object_image<3>(), EdgeMapOptions{}, false, "gvf");
  return e;
}

// grad f as an ITK image (x fastest, as ours).
VectorImage::Pointer itk_input() {
  const EdgeMap<3>& e = edges();
  VectorImage::Pointer image = VectorImage::New();
  VectorImage::SizeType size;
  for (int a = 0; a < 3; ++a) size[a] = e.grid.size[a];
  image->SetRegions(VectorImage::RegionType(size));
  image->Allocate();
  Vector3f* out = image->GetBufferPointer();
  for (size_t l = 0; l < e.f.size(); ++l)
    for (int a = 0; a < 3; ++a) out[l][a] = e.grad_f[a][l];
  return image;
}

std::array<std::vector<float>, 3> ours_result, itk_result;

void BM_DsnakeExplicitGvf(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  const EdgeMap<3>& e = edges();
  std::vector<float> b(e.f.size());
  std::vector<const std::vector<float>*> c;
  std::vector<std::vector<float>*> out;
  for (int a = 0; a < 3; ++a) c.push_back(&e.grad_f[a]), out.push_back(&ours_result[a]);
  GvfSolveOptions o;
  o.solver = GvfSolver::kExplicit, o.mu = kMu, o.iterations = kIterations, o.tolerance = 0, o.time_step = kItkTimeStep;
  for (auto _ : state) {
    for (size_t l = 0; l < b.size(); ++l)
      b[l] = e.grad_f[0][l] * e.grad_f[0][l] + e.grad_f[1][l] * e.grad_f[1][l] + e.grad_f[2][l] * e.grad_f[2][l];
    for (int a = 0; a < 3; ++a) ours_result[a] = e.grad_f[a];
    solve_gvf(e.grid, b, c, out, o);
  }
}
BENCHMARK(BM_DsnakeExplicitGvf)->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ItkGradientVectorFlow(benchmark::State& state) {
  itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(static_cast<int>(state.range(0)));
  const VectorImage::Pointer input = itk_input();
  using Filter = itk::GradientVectorFlowImageFilter<VectorImage, VectorImage, float>;
  VectorImage::Pointer result;
  for (auto _ : state) {
    Filter::Pointer gvf = Filter::New();
    gvf->SetInput(input);
    gvf->SetLaplacianFilter(Filter::LaplacianFilterType::New());
    gvf->SetNoiseLevel(kMu);
    gvf->SetIterationNum(kIterations);
    gvf->Update();
    result = gvf->GetOutput();
  }
  const Vector3f* v = result->GetBufferPointer();
  const size_t n = edges().f.size();
  for (int a = 0; a < 3; ++a) {
    itk_result[a].resize(n);
    for (size_t l = 0; l < n; ++l) itk_result[a][l] = v[l][a];
  }
}
BENCHMARK(BM_ItkGradientVectorFlow)->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond)->UseRealTime()
    ->Iterations(1);

// Keeps each run's time per iteration (median when repeated) to print the ratios at the end.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs)
      if (r.run_type == Run::RT_Iteration || r.aggregate_name == "median")
        times[r.run_name.str()] = r.GetAdjustedRealTime();
  }
  std::map<std::string, double> times;
};

}  // namespace
}  // namespace dsnake

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  dsnake::RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  for (const char* threads : {"1", "2"}) {
    const auto ours = reporter.times.find(std::string("BM_DsnakeExplicitGvf/threads:") + threads + "/real_time");
    const auto itk = reporter.times.find(std::string("BM_ItkGradientVectorFlow/threads:") + threads + "/iterations:1/real_time");
    if (ours != reporter.times.end() && itk != reporter.times.end())
      std::printf("%s thread(s): ITK %.0f ms, dsnake %.0f ms, ITK / dsnake = %.1f\n", threads, itk->second,
                  ours->second, itk->second / ours->second);
  }
  double diff = 0, largest = 0;
  for (int a = 0; a < 3; ++a)
    for (size_t l = 0; l < dsnake::itk_result[a].size() && l < dsnake::ours_result[a].size(); ++l) {
      diff = std::max(diff, double(std::abs(dsnake::itk_result[a][l] - dsnake::ours_result[a][l])));
      largest = std::max(largest, double(std::abs(dsnake::itk_result[a][l])));
    }
  if (largest > 0) std::printf("largest |v_ITK - v_dsnake| / max |v_ITK| = %.2e\n", diff / largest);
  benchmark::Shutdown();
  return 0;
}
