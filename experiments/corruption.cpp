#include "experiments/corruption.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace dsnake {

template <int D>
void apply_corruption(Image<D>& image, JsonReader& r, uint64_t seed, int index) {
  std::string type;
  r.require("type", type);
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull * uint64_t(index + 1));
  if (image.empty()) return;
  const auto [lo_it, hi_it] = std::minmax_element(image.data().begin(), image.data().end());
  const float lo = *lo_it, hi = *hi_it;
  if (type == "outliers") {
    double fraction = 0.01;
    r.read("fraction", fraction);
    r.expect(fraction >= 0 && fraction <= 1, "fraction", "must be in [0, 1]");
    std::bernoulli_distribution flip(fraction);
    for (auto& v : image.data())
      if (flip(rng)) v = (v - lo <= hi - v) ? hi : lo;
  } else if (type == "noise") {
    double sigma = 10;
    r.read("sigma", sigma);
    r.expect(sigma >= 0, "sigma", "must be >= 0");
    std::normal_distribution<double> noise(0.0, sigma);
    for (auto& v : image.data()) v = static_cast<float>(std::clamp(v + noise(rng), 0.0, 255.0));
  } else if (type == "perturb") {
    double radius = 1;
    r.read("radius", radius);
    r.expect(radius >= 0, "radius", "must be >= 0");
    const int64_t n_lo = std::count(image.data().begin(), image.data().end(), lo);
    const int64_t n_hi = std::count(image.data().begin(), image.data().end(), hi);
    double fg = n_lo <= n_hi ? lo : hi;
    r.read("foreground", fg);
    const float foreground = static_cast<float>(fg);
    const float background = foreground == lo ? hi : lo;
    const auto& g = image.grid();
    Image<D> out(g, background);
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int64_t l = 0; l < image.num_voxels(); ++l) {
      if (image[l] != foreground) continue;
      Point<D> dir;
      do {
        for (int a = 0; a < D; ++a) dir[a] = gauss(rng);
      } while (dir.norm() < 1e-12);
      const Point<D> x = g.to_physical(g.index(l)) + radius * unit(rng) * dir.normalized();
      const Point<D> c = g.to_continuous_index(x);
      GridIndex<D> idx;
      bool inside = true;
      for (int a = 0; a < D; ++a) {
        idx[a] = static_cast<int>(std::lround(c[a]));
        inside &= idx[a] >= 0 && idx[a] < g.size[a];
      }
      if (inside) out.at(idx) = foreground;
    }
    image = std::move(out);
  } else {
    r.fail("type", "unknown corruption \"" + type + "\" (known: outliers, noise, perturb)");
  }
}

template void apply_corruption<2>(Image<2>&, JsonReader&, uint64_t, int);
template void apply_corruption<3>(Image<3>&, JsonReader&, uint64_t, int);

}  // namespace dsnake
