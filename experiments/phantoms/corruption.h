// Seeded image corruptions of the paper's robustness experiments (§8), applied in order:
//  - "outliers" {fraction p}: each voxel flips to the other grey level with probability p
//    (values nearer the minimum go to the maximum and vice versa; a binary image stays binary);
//  - "noise" {sigma}: additive white Gaussian noise, clamped to [0, 255];
//  - "perturb" {radius r}: every foreground voxel moves a random distance <= r (physical
//    units) in a random direction onto a background canvas; the image stays binary.
//    The foreground is the less frequent of the two extreme grey levels unless "foreground" is given.
#pragma once

#include "framework/core/image.h"
#include "framework/core/json_reader.h"
#include "framework/core/options.h"
#include "framework/core/options_schema.h"

#include <cstdint>
#include <string>
#include <vector>

namespace dsnake {

enum class CorruptionType { kOutliers, kNoise, kPerturb };
template <>
struct EnumNames<CorruptionType> {
  static constexpr std::array<std::pair<CorruptionType, const char*>, 3> table{
      {{CorruptionType::kOutliers, "outliers"}, {CorruptionType::kNoise, "noise"}, {CorruptionType::kPerturb, "perturb"}}};
};

struct OutliersOptions {
  double fraction = 0.01;
  template <class V>
  void visit(V& v) {
    v(fraction, Key{"fraction", "1", "probability that a voxel flips to the other grey level", Range::closed(0, 1)});
  }
};
struct NoiseOptions {
  double sigma = 10;
  template <class V>
  void visit(V& v) {
    v(sigma, Key{"sigma", "grey levels", "standard deviation of the additive Gaussian noise", Range::at_least(0)});
  }
};
struct PerturbOptions {
  double radius = 1;
  std::optional<double> foreground;  // default: the less frequent of the two extreme grey levels
  template <class V>
  void visit(V& v) {
    v(radius, Key{"radius", "mm", "largest distance a foreground voxel moves", Range::at_least(0)});
    v(foreground, Key{"foreground", "grey level", "the foreground's grey level (default: the less frequent extreme level)"});
  }
};

// One entry of "corruption": its type and that type's options.
struct CorruptionSpec {
  CorruptionType type = CorruptionType::kOutliers;
  OutliersOptions outliers;
  NoiseOptions noise;
  PerturbOptions perturb;
};

// The corruption types as declared: name, summary and the keys of its options (from visit()),
// in the order of EnumNames<CorruptionType>; for the schema and the documentation.
struct CorruptionKind {
  std::string name, summary;
  nlohmann::ordered_json schema_properties;
  std::vector<KeyRow> rows;
};
const std::vector<CorruptionKind>& corruption_kinds();

// Reads one corruption object ({"type": ..., options}); unknown keys throw.
CorruptionSpec read_corruption(JsonReader& reader);

// Applies one corruption. The random stream derives from the experiment seed and the
// corruption's position in the list only.
template <int D>
void apply_corruption(Image<D>& image, const CorruptionSpec& corruption, uint64_t seed, int index);

}  // namespace dsnake
