// The benchmarks' shared test object (bench_fields, bench_potential): a smooth ellipsoid in the
// paper's lung-volume size, or a disk in 512^2, built once per process.
#pragma once

#include "framework/core/image.h"

#include <cmath>

namespace dsnake::bench {

// An ellipsoid (semi-axes 80, 110, 28 voxels; 85 inside, 170 outside, logistic edge of 1.5
// voxels) in 230 x 300 x 80, or a disk of radius 150 in 512^2.
template <int D>
const Image<D>& object_image() {
  static const Image<D> image = [] {
    Grid<D> g;
    Point<D> semi;
    if constexpr (D == 3) {
      g.size = GridIndex<3>(230, 300, 80);
      semi = Point<3>(80, 110, 28);
    } else {
      g.size = GridIndex<2>(512, 512);
      semi = Point<2>(150, 150);
    }
    Image<D> img(g);
    const Point<D> c = (g.size.template cast<double>() - Point<D>::Ones()) / 2;
#pragma omp parallel for schedule(static)
    for (int64_t l = 0; l < g.num_voxels(); ++l) {
      const Point<D> x = g.to_physical(g.index(l)) - c;
      const double r = x.cwiseQuotient(semi).norm();  // 1 on the surface
      const double d = (r - 1.0) * semi.minCoeff();    // ~ signed distance near the surface
      img[l] = static_cast<float>(85.0 + 85.0 / (1.0 + std::exp(-d / 1.5)));
    }
    return img;
  }();
  return image;
}

}  // namespace dsnake::bench
