#include "experiments/phantoms/corruption.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace dsnake {

namespace {

template <class O>
CorruptionKind kind_of(CorruptionType type, const char* summary) {
  return {enum_name(type), summary, options_schema<O>(), options_rows<O>()};
}

}  // namespace

const std::vector<CorruptionKind>& corruption_kinds() {
  static const std::vector<CorruptionKind> kinds = {
      kind_of<OutliersOptions>(CorruptionType::kOutliers, "each voxel flips to the other grey level with probability `fraction`"),
      kind_of<NoiseOptions>(CorruptionType::kNoise, "additive white Gaussian noise, clamped to [0, 255]"),
      kind_of<PerturbOptions>(CorruptionType::kPerturb,
                              "every foreground voxel moves a random distance <= `radius` in a random direction")};
  return kinds;
}

CorruptionSpec read_corruption(JsonReader& r) {
  CorruptionSpec c;
  std::string type;
  r.require("type", type);
  const auto t = enum_from_name<CorruptionType>(type);
  if (!t) r.fail("type", "unknown corruption \"" + type + "\" (known: " + enum_choices<CorruptionType>() + ")");
  c.type = *t;
  switch (c.type) {
    case CorruptionType::kOutliers: read_options(r, c.outliers); break;
    case CorruptionType::kNoise: read_options(r, c.noise); break;
    case CorruptionType::kPerturb: read_options(r, c.perturb); break;
  }
  r.finish();
  return c;
}

template <int D>
void apply_corruption(Image<D>& image, const CorruptionSpec& c, uint64_t seed, int index) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull * uint64_t(index + 1));
  if (image.empty()) return;
  const auto [lo_it, hi_it] = std::minmax_element(image.data().begin(), image.data().end());
  const float lo = *lo_it, hi = *hi_it;
  if (c.type == CorruptionType::kOutliers) {
    std::bernoulli_distribution flip(c.outliers.fraction);
    for (auto& v : image.data())
      if (flip(rng)) v = (v - lo <= hi - v) ? hi : lo;
  } else if (c.type == CorruptionType::kNoise) {
    std::normal_distribution<double> noise(0.0, c.noise.sigma);
    for (auto& v : image.data()) v = static_cast<float>(std::clamp(v + noise(rng), 0.0, 255.0));
  } else {
    const double radius = c.perturb.radius;
    const int64_t n_lo = std::count(image.data().begin(), image.data().end(), lo);
    const int64_t n_hi = std::count(image.data().begin(), image.data().end(), hi);
    const double fg = c.perturb.foreground ? *c.perturb.foreground : n_lo <= n_hi ? lo : hi;
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
  }
}

template void apply_corruption<2>(Image<2>&, const CorruptionSpec&, uint64_t, int);
template void apply_corruption<3>(Image<3>&, const CorruptionSpec&, uint64_t, int);

}  // namespace dsnake
