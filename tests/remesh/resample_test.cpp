#include "remesh/resample.h"

#include "remesh/registry.h"

#include "framework/core/errors.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>

namespace dsnake {
namespace {

TEST(ResampleRemesher, EdgesFallBetweenMinAndMaxAndAnchorsStay) {
  // A 40 x 20 rectangle with its 4 corners as deformation vertices and a crowded free stretch.
  PointList<2> q = {{0, 0}, {40, 0}, {40, 20}, {0, 20}};
  std::vector<int> ids = {0, 1, 2, 3};
  for (int k = 1; k < 40; ++k) {  // 39 free vertices squeezed on the last edge
    q.push_back(Point<2>(0, 20 - 0.5 * k / 2.0));
    ids.push_back(-1);
  }
  Snake<2> s(q, Connectivity::polygon(static_cast<int>(q.size())), ids);
  ResampleRemesher r({0.8, 2.0});
  const auto report = r.apply(s, {});
  EXPECT_EQ(report.vertices_before, 43);
  const auto& p = s.positions();
  const int n = s.num_vertices();
  for (int v = 0; v < n; ++v) {
    const double len = (p[(v + 1) % n] - p[v]).norm();
    EXPECT_GE(len, 0.8 - 1e-9);
    EXPECT_LE(len, 2.0 + 1e-9);
  }
  // Anchors keep ids, positions and order.
  int last = -1;
  for (int t = 0; t < 4; ++t) {
    const int v = s.vertex_of_template_id(t);
    ASSERT_GE(v, 0);
    EXPECT_EQ(p[v], q[t]);
    EXPECT_GT(v, last);
    last = v;
  }
  // Perimeter 120 with max edge 2: 60 edges.
  EXPECT_EQ(n, 60);
  EXPECT_EQ(s.topology_version(), 1u);
  // A second pass changes nothing.
  r.apply(s, {});
  EXPECT_EQ(s.topology_version(), 1u);
}

// The vertex budget: a resampling past it is found before anything is allocated and leaves the
// snake as it was; at the budget it resamples. A length whose count exceeds int's range (a cast
// that would be undefined) is refused the same way.
TEST(ResampleRemesher, AResamplingPastTheVertexBudgetLeavesTheSnakeAsItWas) {
  const PointList<2> q = {{0, 0}, {40, 0}, {40, 20}, {0, 20}};  // perimeter 120
  const Snake<2> start(q, Connectivity::polygon(4), {0, -1, -1, -1});
  RemeshContext<2> context;
  context.max_vertices = 59;
  Snake<2> s = start;
  const auto over = ResampleRemesher({0.8, 2.0}).apply(s, context);  // needs 60
  EXPECT_TRUE(over.over_budget);
  EXPECT_EQ(s.positions(), start.positions());
  EXPECT_EQ(s.topology_version(), start.topology_version());
  context.max_vertices = 60;
  const auto fits = ResampleRemesher({0.8, 2.0}).apply(s, context);
  EXPECT_FALSE(fits.over_budget);
  EXPECT_EQ(s.num_vertices(), 60);
  // 120 / 2e-300 edges: more than any int; refused without a cast (UBSan would flag one).
  context.max_vertices = std::numeric_limits<int>::max();
  s = start;
  const auto huge = ResampleRemesher({1e-300, 2e-300}).apply(s, context);
  EXPECT_TRUE(huge.over_budget);
  EXPECT_EQ(s.num_vertices(), 4);
  // The stage's refinement length is its max_edge (what the assembly checks against the budget).
  const auto length = ResampleRemesher({0.8, 2.0}).refinement_length();
  ASSERT_TRUE(length.has_value());
  EXPECT_EQ(length->key, "max_edge");
  EXPECT_EQ(length->length, 2.0);
}

TEST(ResampleRemesher, RejectsInconsistentOptions) {
  const auto j = nlohmann::json::parse(R"({"type": "resample", "min_edge": 2, "max_edge": 3})");
  JsonReader reader(j, "f", "phases[0].remesh[0]");
  EXPECT_THROW(remesher_registry<2>().create(reader), InputError);
}

}  // namespace
}  // namespace dsnake
