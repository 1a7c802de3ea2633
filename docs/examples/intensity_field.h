// docs/extending.md's worked example of a new external field: the image's own intensity
// gradient, normalised by its largest magnitude, pointing towards brighter (or darker) voxels,
//   F(x) = sign * grad I(x) / max |grad I|,   sign = +1 ("toward": "bright"), -1 ("dark"),
// central differences on the grid, sampled by linear interpolation. A region-growing force for a
// structure brighter or darker than its surroundings; no potential (the global view has none).
#pragma once

#include "framework/core/external_field.h"
#include "framework/core/options.h"

namespace dsnake {

enum class IntensityDirection { kBright, kDark };
template <>
struct EnumNames<IntensityDirection> {
  static constexpr std::array<std::pair<IntensityDirection, const char*>, 2> table{
      {{IntensityDirection::kBright, "bright"}, {IntensityDirection::kDark, "dark"}}};
};

struct IntensityFieldOptions {
  IntensityDirection toward = IntensityDirection::kBright;

  template <class V>
  void visit(V& v) {
    v(toward, Key{"toward", "", "the force points up the intensity gradient (bright) or down it (dark)"});
  }
};

template <int D>
class IntensityField final : public ExternalField<D> {
 public:
  using Options = IntensityFieldOptions;
  static constexpr const char* kType = "intensity";
  static constexpr const char* kSummary = "the normalised intensity gradient, towards bright or dark voxels";

  explicit IntensityField(const Options& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  void compute(const Image<D>& image) override;
  Point<D> force(const Point<D>& x, const Point<D>& normal) const override { return vectors_.sample(x); }
  const VectorField<D>& vectors() const override { return vectors_; }

 private:
  Options options_;
  VectorField<D> vectors_;
};

}  // namespace dsnake
