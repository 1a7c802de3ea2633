// max_force_magnitude and median_force_magnitude (framework/core/force_strength.h): the numbers
// result.json's "external_force" reports, against hand-computed values.
#include "framework/core/force_strength.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dsnake {
namespace {

// F(x) = (x, 0): |F| at a vertex is |x|; the grid holds |F| up to 4 (its largest x).
class RampField final : public ExternalField<2> {
 public:
  RampField() : vectors_(Grid<2>{GridIndex<2>(5, 2), Point<2>(1, 1), Point<2>(0, 0)}) {
    for (int64_t l = 0; l < vectors_.num_voxels(); ++l) vectors_[l] = Point<2>(double(l % 5), 0);
  }
  std::string type() const override { return "ramp"; }
  void compute(const Image<2>&) override {}
  Point<2> force(const Point<2>& x, const Point<2>&) const override { return Point<2>(x.x(), 0); }
  const VectorField<2>& vectors() const override { return vectors_; }

 private:
  VectorField<2> vectors_;
};

Snake<2> polygon(PointList<2> q) {
  const int n = static_cast<int>(q.size());
  std::vector<int> ids(n);
  for (int i = 0; i < n; ++i) ids[i] = i;
  return Snake<2>(std::move(q), Connectivity::polygon(n), ids);
}

TEST(ForceStrength, MaxIsTheLargestSampledVector) {
  RampField field;
  EXPECT_DOUBLE_EQ(max_force_magnitude(field), 4.0);
}

TEST(ForceStrength, MedianOverTheVerticesOddAndEven) {
  RampField field;
  EXPECT_DOUBLE_EQ(median_force_magnitude(field, polygon({{3, 0}, {-1, 1}, {0.5, 2}})), 1.0);
  EXPECT_DOUBLE_EQ(median_force_magnitude(field, polygon({{3, 0}, {-1, 1}, {0.5, 2}, {2, 1}})), 1.5);
  EXPECT_TRUE(std::isnan(median_force_magnitude(field, polygon({{NAN, 0}, {-1, 1}, {0.5, 2}}))));
}

}  // namespace
}  // namespace dsnake
