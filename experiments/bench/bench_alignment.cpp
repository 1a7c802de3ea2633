// The image init's engine (framework/core/image_alignment.h) on a structure-sized region:
// Colin27's T1 (181 x 217 x 181, 1 mm; scripts/fetch_scans.sh) onto itself moved by a similarity
// (4 deg, scale 1.04, (3, -2, 2.5) mm), a 40 mm box about the left basal ganglia plus the
// default 10 mm margin, levels 4, 2, 1 mm; rigid, similarity and affine, on 1 and 2 threads.
#include "framework/core/image_alignment.h"
#include "framework/io/image_io.h"

#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <omp.h>

namespace dsnake {
namespace {

const Point<3> kCentre(22, -2, 2);  // LPS mm

AffineMap<3> truth() {
  AffineMap<3> m;
  m.matrix = 1.04 * Eigen::AngleAxisd(4.0 * 3.14159265358979323846 / 180.0, Point<3>(1, 2, 3).normalized()).toRotationMatrix();
  m.translation = kCentre - m.matrix * kCentre + Point<3>(3, -2, 2.5);
  return m;
}

const Image<3>& reference() {
  static const Image<3> image = read_image<3>(std::string(DSNAKE_SOURCE_DIR) + "/data/scans/mricron/ch2.nii.gz");
  return image;
}

// The reference moved by truth(): S(y) = R(T^-1 y).
const Image<3>& scan() {
  static const Image<3> image = [] {
    const Image<3>& r = reference();
    const AffineMap<3> inv = truth().inverse();
    Image<3> out(r.grid());
#pragma omp parallel for schedule(static)
    for (int64_t l = 0; l < out.num_voxels(); ++l)
      out[l] = float(r.sample(r.grid().to_frame(inv.apply(r.grid().to_world(r.grid().to_physical(r.grid().index(l)))))));
    return out;
  }();
  return image;
}

void BM_AlignBasalGanglia3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  ImageAlignmentOptions o;
  o.model = static_cast<AlignmentModel>(state.range(1));
  const WorldBox<3> region{Point<3>(kCentre.array() - 20.0), Point<3>(kCentre.array() + 20.0)};
  scan();
  ImageAlignmentResult<3> r;
  for (auto _ : state) {
    r = align_images<3>(reference(), scan(), region, {}, o);
    benchmark::DoNotOptimize(r);
  }
  const AffineMap<3> t = truth();
  double err = 0;
  for (int k = 0; k < 8; ++k) {
    Point<3> x;
    for (int a = 0; a < 3; ++a) x[a] = (k >> a) & 1 ? region.hi[a] : region.lo[a];
    err = std::max(err, (r.transform.apply(x) - t.apply(x)).norm());
  }
  state.counters["corner_error_mm"] = err;
  state.counters["steps"] = r.iterations;
  state.counters["ncc"] = r.ncc_after;
  state.SetLabel(enum_name(o.model));
}
// threads, model (0 similarity, 1 rigid, 2 affine)
BENCHMARK(BM_AlignBasalGanglia3d)
    ->Args({1, 1})->Args({1, 0})->Args({1, 2})->Args({2, 0})->Args({2, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
