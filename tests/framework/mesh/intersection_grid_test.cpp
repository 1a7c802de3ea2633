// The speed-ups of the mesh-edit kernel's crossing checks (framework/mesh/edit_mesh.h) must not
// change what they compute:
// - the flat intersection grid returns exactly the brute-force answer (every live triangle
//   tested) on random triangle soups, also after triangles move, come and go;
// - the cheap plane rejections before the exact pair tests (framework/geometry/triangle_pairs.h)
//   never hide a crossing (checked against independent tests: the framework's exact
//   triangle-triangle test, and a segment-triangle solve written here);
// - min_angle (one atan2, at the corner opposite the shortest edge) is the smallest of the three.
#include "framework/geometry/predicates.h"
#include "framework/geometry/triangle_measures.h"
#include "framework/mesh/edit_mesh.h"
#include "tests/test_meshes.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace dsnake {
namespace {

// A closed mesh (a coarse sphere) plus `extra` random small triangles in and around it, on
// their own vertices: a soup whose triangles cross each other and the sphere here and there.
struct Soup {
  EditMesh mesh;
  std::vector<int> extra;  // triangle slots of the random triangles
};

Soup random_soup(unsigned seed, int extra, double size) {
  Soup soup{EditMesh(test::icosphere(2, 1.0)), {}};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> centre(-1.3, 1.3), offset(-size, size);
  for (int i = 0; i < extra; ++i) {
    const Point<3> c(centre(rng), centre(rng), centre(rng));
    Triangle t;
    for (int& v : t) v = soup.mesh.add_vertex(c + Point<3>(offset(rng), offset(rng), offset(rng)));
    soup.extra.push_back(soup.mesh.add_triangle(t));
  }
  return soup;
}

// A random query triangle on fresh vertices, sometimes reusing one or two vertices of the mesh
// (so that the shared-vertex and shared-edge tests are exercised too).
Triangle random_query(EditMesh& m, std::mt19937& rng, double size) {
  std::uniform_real_distribution<double> centre(-1.3, 1.3), offset(-size, size);
  std::uniform_int_distribution<int> pick(0, 161), share(0, 2);
  const Point<3> c(centre(rng), centre(rng), centre(rng));
  Triangle t;
  for (int& v : t) v = m.add_vertex(c + Point<3>(offset(rng), offset(rng), offset(rng)));
  const int s = share(rng);
  if (s >= 1) t[0] = pick(rng);
  if (s == 2) {
    const int f = m.corners(t[0]).front().f;
    const auto& g = m.tri(f);
    const int k = g[0] == t[0] ? 0 : (g[1] == t[0] ? 1 : 2);
    t[1] = g[(k + 2) % 3];  // the edge t[0] -> t[1] runs opposite to g's, as a neighbour would
  }
  return t;
}

TEST(IntersectionGrid, SameAnswerAsBruteForceOnRandomSoups) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE(seed);
    Soup soup = random_soup(seed, 300, 0.15);
    EditMesh& m = soup.mesh;
    std::mt19937 rng(100 + seed);
    int hits = 0, queries = 0;
    auto check = [&](int rounds) {
      for (int i = 0; i < rounds; ++i) {
        const Triangle q[2] = {random_query(m, rng, 0.2), random_query(m, rng, 0.2)};
        const int ignore[2] = {soup.extra[i % soup.extra.size()], 7};
        for (int n = 1; n <= 2; ++n) {
          const std::span<const Triangle> ts(q, n);
          const bool expected = m.intersects_any_brute_force(ts, ignore);
          ASSERT_EQ(m.intersects_any(ts, ignore), expected) << "query " << i;
          hits += expected;
          ++queries;
        }
      }
    };
    // Queries aimed at given triangles: a thin triangle through the centroid along the normal.
    auto check_through = [&](const std::vector<int>& targets) {
      for (int f : targets) {
        if (!m.tri_alive(f)) continue;
        const auto& t = m.tri(f);
        const Point<3> c = (m.pos(t[0]) + m.pos(t[1]) + m.pos(t[2])) / 3;
        const Point<3> n = triangle_normal(m.pos(t[0]), m.pos(t[1]), m.pos(t[2]));
        const Point<3> side = 0.02 * (m.pos(t[1]) - m.pos(t[0])).normalized();
        const Triangle q = {m.add_vertex(c + 0.05 * n), m.add_vertex(c - 0.05 * n), m.add_vertex(c - 0.05 * n + side)};
        const bool expected = m.intersects_any_brute_force(std::span<const Triangle>(&q, 1), {});
        ASSERT_EQ(m.intersects(q, {}), expected) << "through triangle " << f;
        hits += expected;
        ++queries;
      }
    };
    check(200);
    check_through(soup.extra);
    // Move (far: across cells), remove and add triangles after the grid exists: it must follow.
    std::uniform_real_distribution<double> jump(-0.4, 0.4), far(-1.5, 1.5);
    std::vector<int> moved;
    for (size_t i = 0; i < soup.extra.size(); i += 3) {
      const Triangle t = m.tri(soup.extra[i]);
      const Point<3> d(far(rng), far(rng), far(rng));
      for (int v : t) m.move_vertex(v, m.pos(v) + d);
      moved.push_back(soup.extra[i]);
    }
    for (size_t i = 0; i < soup.extra.size(); i += 3) {
      const int v = m.tri(soup.extra[i])[0];
      m.move_vertex(v, m.pos(v) + Point<3>(jump(rng), jump(rng), jump(rng)));
    }
    for (size_t i = 1; i < soup.extra.size(); i += 4) m.remove_triangle(soup.extra[i]);
    for (int i = 0; i < 100; ++i) {
      Triangle t;
      for (int& v : t) v = m.add_vertex(Point<3>(jump(rng), jump(rng), jump(rng)) * 3.5);  // partly outside the grid's box
      moved.push_back(m.add_triangle(t));
    }
    check(200);
    check_through(moved);
    check_through(soup.extra);
    // The soups must exercise both answers.
    EXPECT_GT(hits, queries / 10);
    EXPECT_GT(queries - hits, queries / 20);
  }
}

// Disjoint triangles: intersects() (plane rejection, then the exact test) agrees with the
// framework's exact test alone.
TEST(IntersectionGrid, PlaneRejectionNeverHidesACrossing) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int crossings = 0;
  for (int i = 0; i < 3000; ++i) {
    std::array<Point<3>, 3> a, b;
    for (auto& x : a) x = {u(rng), u(rng), u(rng)};
    for (auto& x : b) x = {u(rng), u(rng), u(rng)};
    Snake<3> s = test::icosphere(0, 0.01);  // a tiny closed mesh far away, only to hold vertices
    PointList<3> p = s.positions();
    for (auto& x : p) x += Point<3>(50, 50, 50);
    s.set_topology(std::move(p), s.connectivity(), s.template_ids());
    EditMesh m(s);
    const Triangle ta = {m.add_vertex(a[0]), m.add_vertex(a[1]), m.add_vertex(a[2])};
    const Triangle tb = {m.add_vertex(b[0]), m.add_vertex(b[1]), m.add_vertex(b[2])};
    m.add_triangle(tb);
    const bool exact = triangles_intersect(a, b);
    ASSERT_EQ(m.intersects(ta, {}), exact) << i;
    crossings += exact;
  }
  EXPECT_GT(crossings, 300);
}

// Triangles sharing one vertex: they conflict iff an edge opposite the shared vertex pierces
// the other triangle; checked against a direct solve p + t (q - p) = a + u (b - a) + v (c - a).
bool segment_pierces(const Point<3>& p, const Point<3>& q, const Point<3>& a, const Point<3>& b,
                     const Point<3>& c) {
  Eigen::Matrix3d A;
  A << q - p, a - b, a - c;
  const Eigen::Vector3d x = A.fullPivLu().solve(a - p);  // (t, u, v)
  return x[0] >= 0 && x[0] <= 1 && x[1] >= 0 && x[2] >= 0 && x[1] + x[2] <= 1;
}

TEST(IntersectionGrid, SharedVertexTestMatchesADirectSolve) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  int pierced = 0;
  for (int i = 0; i < 3000; ++i) {
    Snake<3> s = test::icosphere(0, 0.01);
    PointList<3> p = s.positions();
    for (auto& x : p) x += Point<3>(50, 50, 50);
    s.set_topology(std::move(p), s.connectivity(), s.template_ids());
    EditMesh m(s);
    const Point<3> o(u(rng), u(rng), u(rng)), a1(u(rng), u(rng), u(rng)), a2(u(rng), u(rng), u(rng)),
        b1(u(rng), u(rng), u(rng)), b2(u(rng), u(rng), u(rng));
    const int vo = m.add_vertex(o);
    const Triangle ta = {vo, m.add_vertex(a1), m.add_vertex(a2)};
    const Triangle tb = {vo, m.add_vertex(b1), m.add_vertex(b2)};
    m.add_triangle(tb);
    const bool expected = segment_pierces(a1, a2, o, b1, b2) || segment_pierces(b1, b2, o, a1, a2);
    ASSERT_EQ(m.intersects(ta, {}), expected) << i;
    pierced += expected;
  }
  EXPECT_GT(pierced, 100);
}

TEST(MinAngle, IsTheSmallestOfTheThreeAngles) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 1000; ++i) {
    const Point<3> a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    const double expected = std::min({angle_at(a, b, c), angle_at(b, c, a), angle_at(c, a, b)});
    EXPECT_NEAR(min_angle(a, b, c), expected, 1e-14);
  }
  // Hand-computed: a 30-60-90 triangle.
  EXPECT_NEAR(min_angle({0, 0, 0}, {std::sqrt(3.0), 0, 0}, {0, 1, 0}), std::numbers::pi / 6, 1e-15);
}

TEST(MinAngle, KeyIsMinusTheCosineOfTheSmallestAngle) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 1000; ++i) {
    const Point<3> a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    EXPECT_NEAR(min_angle_key(a, b, c), -std::cos(min_angle(a, b, c)), 1e-12);
    EXPECT_NEAR(min_angle_key(c, a, b), min_angle_key(a, b, c), 1e-15);
  }
  // Hand-computed: a 30-60-90 triangle; the threshold keys order as the angles do.
  EXPECT_NEAR(min_angle_key({0, 0, 0}, {std::sqrt(3.0), 0, 0}, {0, 1, 0}), -std::sqrt(3.0) / 2, 1e-15);
  EXPECT_LT(angle_key(0.2), angle_key(0.3));
  // Degenerate: a repeated corner is the key of a zero angle.
  EXPECT_EQ(min_angle_key({1, 2, 3}, {1, 2, 3}, {0, 1, 0}), -1.0);
}

}  // namespace
}  // namespace dsnake
