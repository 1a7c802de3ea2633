// The remeshers' guarantees, on a sphere, a torus and a genus-2 surface, after every stage:
// closed manifold, Euler characteristic unchanged, no self-intersection, deformation vertices
// kept with their ids and exact positions.
#include "framework/metrics/metrics.h"
#include "remesh/delaunay.h"
#include "remesh/refine.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <string>

namespace dsnake {
namespace {

struct Shape {
  std::string name;
  std::function<Snake<3>()> make;
  double edge;  // typical edge length, for the thresholds
};

std::vector<Shape> shapes() {
  return {{"sphere", [] { return test::with_free_vertices(test::icosphere(2, 5.0), 3); }, 1.7},
          {"torus", [] { return test::with_free_vertices(test::torus(24, 10), 2); }, 0.8},
          {"genus2", [] { return test::with_free_vertices(test::two_hole_slab(2), 2); }, 1.0}};
}

// Checks every guarantee of the snake `s` against the state `before` it was remeshed from.
void expect_guarantees(const Snake<3>& before, const Snake<3>& s, const std::string& what) {
  SCOPED_TRACE(what);
  // Checked from the triangles alone (a remesher writes its rings back unchecked): closed and
  // manifold, and the rings it wrote are the ones Connectivity::mesh orders.
  const Connectivity rebuilt = Connectivity::mesh(s.num_vertices(), s.connectivity().triangles());
  EXPECT_EQ(rebuilt.closed_manifold_problem(), "");
  for (int v = 0; v < s.num_vertices(); ++v)
    ASSERT_TRUE(std::ranges::equal(s.connectivity().neighbors(v), rebuilt.neighbors(v))) << "ring of vertex " << v;
  EXPECT_EQ(rebuilt.euler_characteristic(), before.connectivity().euler_characteristic());
  EXPECT_EQ(count_self_intersections<3>({s.positions(), s.connectivity()}), 0);
  EXPECT_EQ(s.num_deformation_vertices(), before.num_deformation_vertices());
  for (int v = 0; v < before.num_vertices(); ++v) {
    if (!before.is_deformation_vertex(v)) continue;
    const int w = s.vertex_of_template_id(before.template_id(v));
    ASSERT_GE(w, 0) << "template id " << before.template_id(v) << " lost";
    EXPECT_EQ(s.positions()[w], before.positions()[v]) << "template id " << before.template_id(v) << " moved";
  }
  EXPECT_GT(s.signed_measure(), 0);
}

std::vector<std::unique_ptr<Remesher<3>>> pipeline(double edge) {
  std::vector<std::unique_ptr<Remesher<3>>> p;
  p.push_back(std::make_unique<RefineRemesher>(RefineOptions{0.8 * edge, 0, 0.5}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{}));
  p.push_back(std::make_unique<UniformRemesher>(UniformOptions{2, 45}));
  p.push_back(std::make_unique<DelaunayRemesher>(DelaunayOptions{DelaunayMethod::kPlanar, 30, true, 25}));
  p.push_back(std::make_unique<SimplifyRemesher>(SimplifyOptions{0.3 * edge, 0.8 * edge, 0.1, 45}));
  return p;
}

TEST(RemeshGuarantees, EveryStageOnSphereTorusAndGenus2) {
  for (const auto& shape : shapes()) {
    Snake<3> s = shape.make();
    const int chi = s.connectivity().euler_characteristic();
    EXPECT_EQ(chi, shape.name == "sphere" ? 2 : shape.name == "torus" ? 0 : -2) << shape.name;
    for (int pass = 0; pass < 2; ++pass) {
      for (auto& stage : pipeline(shape.edge)) {
        const Snake<3> before = s;
        stage->apply(s, {});
        expect_guarantees(before, s, shape.name + " pass " + std::to_string(pass) + " " + stage->type());
      }
    }
    EXPECT_GT(s.num_vertices(), shape.make().num_vertices()) << shape.name << ": refinement added vertices";
  }
}

}  // namespace
}  // namespace dsnake
