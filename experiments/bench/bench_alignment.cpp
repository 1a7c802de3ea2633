// The image init's engine (framework/core/image_alignment.h) on a structure-sized region:
// Colin27's T1 (181 x 217 x 181, 1 mm; scripts/fetch_scans.sh) onto itself moved by a similarity
// (4 deg, scale 1.04, (3, -2, 2.5) mm), a 40 mm box about the left basal ganglia plus the
// default 10 mm margin, levels 4, 2, 1 mm; rigid, similarity and affine, on 1 and 2 threads.
// And the whole-image alignment (align_whole_images: a scan in another world frame) of Colin27
// onto itself placed 25 degrees and 58 mm away (the grid moved, the voxels kept), rigid, levels 8, 4 mm.
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

// Colin27's voxels placed by a rigid map of 25 degrees and (40, 30, -30) mm: its grid's origin
// and direction moved (exact, nothing resampled).
AffineMap<3> far_truth() {
  AffineMap<3> m;
  m.matrix = Eigen::AngleAxisd(25.0 * 3.14159265358979323846 / 180.0, Point<3>(0.3, 0.5, 0.81).normalized()).toRotationMatrix();
  m.translation = Point<3>(40, 30, -30);
  return m;
}

void BM_AlignWholeImage3d(benchmark::State& state) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  const AffineMap<3> t = far_truth();
  Grid<3> g = reference().grid();
  g.origin = t.apply(g.origin);
  g.direction = t.matrix * g.direction;
  const Image<3> far(g, std::vector<float>(reference().data().begin(), reference().data().end()));
  ImageAlignmentOptions o;
  o.model = AlignmentModel::kRigid;  // as recipe_3d.json's whole_image
  o.levels = {8.0, 4.0};
  WholeImageAlignment<3> r;
  for (auto _ : state) {
    r = align_whole_images<3>(reference(), far, {}, o);
    benchmark::DoNotOptimize(r);
  }
  double err = 0;
  for (int k = 0; k < 8; ++k) {
    Point<3> x;
    for (int a = 0; a < 3; ++a) x[a] = (k >> a) & 1 ? kCentre[a] + 20.0 : kCentre[a] - 20.0;
    err = std::max(err, (r.fit.transform.apply(x) - t.apply(x)).norm());
  }
  state.counters["corner_error_mm"] = err;
  state.counters["steps"] = r.fit.iterations;
  state.counters["ncc"] = r.fit.ncc_after;
}
BENCHMARK(BM_AlignWholeImage3d)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace dsnake

BENCHMARK_MAIN();
