// The example remesher of docs/extending.md (docs/examples/free_smoothing_remesher.*): one
// registration line; free vertices move to the hand-computed point, deformation vertices, the
// connectivity and the topology version stay (the remesher contract, framework/core/remesher.h).
#include "docs/examples/free_smoothing_remesher.h"
#include "framework/core/registry.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace dsnake {
namespace {

TEST(ExtendingExample, FreeSmoothingMovesOnlyFreeVertices) {
  Registry<Remesher<2>> registry;
  registry.add<FreeSmoothingRemesher<2>>();
  nlohmann::json spec = {{"type", "free_smoothing"}, {"lambda", 0.5}};
  JsonReader r(spec, "test.json", "phases[0].remesh[0]");
  auto remesher = registry.read(r).build();

  // A square whose vertex 1 is free (template id -1), pushed out to (3, 0).
  PointList<2> q = {Point<2>(0, 0), Point<2>(3, 0), Point<2>(2, 2), Point<2>(0, 2)};
  Snake<2> snake(q, Connectivity::polygon(4), {0, -1, 1, 2});
  const uint64_t version = snake.topology_version();
  const RemeshReport report = remesher->apply(snake, RemeshContext<2>{});
  EXPECT_EQ(report.stage, "free_smoothing");
  EXPECT_EQ(report.vertices_after, 4);
  // the ring of vertex 1 is {0, 2}: mean (1, 1); (3, 0) + 0.5 ((1, 1) - (3, 0)) = (2, 0.5)
  EXPECT_NEAR(snake.positions()[1].x(), 2.0, 1e-15);
  EXPECT_NEAR(snake.positions()[1].y(), 0.5, 1e-15);
  for (int v : {0, 2, 3}) EXPECT_EQ(snake.positions()[v], q[v]);
  EXPECT_EQ(snake.topology_version(), version);
}

}  // namespace
}  // namespace dsnake
