// The safety checks behind every 3D stage: EditMesh::intersects (crossing, piercing at a
// shared vertex, folding at a shared edge) and the closed-manifold guard.
#include "framework/mesh/edit_mesh.h"

#include "tests/test_meshes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace dsnake {
namespace {


TEST(EditMesh, DetectsTrianglesThatCrossOrFoldOntoTheSurface) {
  EditMesh m(test::icosphere(1, 1.0));
  // A triangle from the centre to well outside crosses the sphere.
  const int a = m.add_vertex({0, 0, 0}), b = m.add_vertex({2, 0.1, 0}), c = m.add_vertex({2, -0.1, 0.1});
  EXPECT_TRUE(m.intersects({a, b, c}, {}));
  // A small triangle far outside touches nothing.
  const int d = m.add_vertex({3, 3, 3}), e = m.add_vertex({3.1, 3, 3}), f = m.add_vertex({3, 3.1, 3});
  EXPECT_FALSE(m.intersects({d, e, f}, {}));
  // A triangle on an existing vertex whose opposite edge pierces the surface: caught through
  // the shared-vertex test.
  const int g = m.add_vertex(1.5 * m.pos(0) - 1.2 * m.pos(0).normalized().cross(Point<3>(0, 0, 1)).normalized());
  const int h = m.add_vertex(-0.3 * m.pos(0));
  EXPECT_TRUE(m.intersects({0, g, h}, {}));
  // An existing triangle duplicated (shared edge and vertex) is a fold; ignoring the original
  // it is fine.
  const Triangle t = m.tri(0);
  EXPECT_TRUE(m.intersects(t, {}));
  const int self[1] = {0};
  EXPECT_FALSE(m.intersects(t, self));
  // The same triangle with its third vertex pulled back onto its neighbour's side folds.
  const int f2 = m.face_with_edge(t[1], t[0]);
  const int o = m.opposite(f2, t[1], t[0]);
  const int fold = m.add_vertex(0.999 * m.pos(o) + 0.0005 * (m.pos(t[0]) + m.pos(t[1])));
  const int ignore[1] = {0};
  EXPECT_TRUE(m.intersects({t[0], t[1], fold}, ignore));
}

TEST(EditMesh, RingsAreCounterClockwiseAndFlipsKeepTheMeshClosed) {
  Snake<3> s = test::icosphere(1, 1.0);
  EditMesh m(s);
  std::vector<int> ring;
  m.ring(0, ring);
  ASSERT_EQ(ring.size(), 5u);
  // Counter-clockwise seen from outside: (r_i - v) x (r_i+1 - v) points outward.
  for (size_t i = 0; i < ring.size(); ++i)
    EXPECT_GT((m.pos(ring[i]) - m.pos(0)).cross(m.pos(ring[(i + 1) % 5]) - m.pos(0)).dot(m.pos(0)), 0);
  // Flipping an edge of the (convex) sphere makes a dent whose new edge bends by 42.6 degrees
  // (the old one by 22.5): refused under a 40-degree limit, done under 60, and the result
  // stays closed with the same Euler characteristic.
  EXPECT_EQ(try_flip(m, 0, ring[0], std::cos(40 * std::numbers::pi / 180)),
            FlipResult::kRejected);
  const auto r = try_flip(m, 0, ring[0], std::cos(60 * std::numbers::pi / 180));
  EXPECT_EQ(r, FlipResult::kFlipped);
  EXPECT_FALSE(m.has_edge(0, ring[0]));
  m.commit(s);
  EXPECT_EQ(s.connectivity().closed_manifold_problem(), "");
  EXPECT_EQ(s.connectivity().euler_characteristic(), 2);
  EXPECT_EQ(s.topology_version(), 1u);
}

// The flat corner store behind EditMesh against lists of corners: random pushes and
// erases on a few vertices, some of them past the kInline corners a vertex holds in place (it
// then spills to a list of its own), must keep each vertex's corners in the order they came.
TEST(CornerFans, KeepTheCornersInTheOrderTheyCameAcrossSpills) {
  constexpr int kVertices = 5;
  CornerFans fans(kVertices - 1);
  fans.add_vertex();
  std::vector<std::vector<MeshCorner>> lists(kVertices);
  uint32_t state = 7;
  auto next = [&](uint32_t n) {
    state = state * 1664525u + 1013904223u;
    return (state >> 8) % n;
  };
  int face = 0;
  size_t most = 0;  // vertex 0's largest count
  for (int step = 0; step < 4000; ++step) {
    const int v = int(next(kVertices));
    // Vertex 0 grows to about 3 kInline corners, the others stay around kInline.
    const int cap = v == 0 ? 3 * CornerFans::kInline : CornerFans::kInline + 1;
    const bool push = lists[v].empty() || (int(lists[v].size()) < cap && next(3) != 0);
    if (push) {
      const MeshCorner c{face++, int(next(100)), int(next(100))};
      fans.push(v, c);
      lists[v].push_back(c);
      if (v == 0) most = std::max(most, lists[0].size());
    } else if (next(4) == 0) {  // undo steps (EditMesh::undo_flip): the last corner off, or one put back
      if (next(2) == 0) {
        fans.pop(v);
        lists[v].pop_back();
      } else {
        const size_t k = next(uint32_t(lists[v].size()));
        const MeshCorner c = lists[v][k];
        ASSERT_EQ(fans.erase_face(v, c.f), int(k));
        fans.insert(v, int(k), c);
      }
    } else {
      const size_t k = next(uint32_t(lists[v].size()));
      ASSERT_EQ(fans.erase_face(v, lists[v][k].f), int(k));  // where it stood
      lists[v].erase(lists[v].begin() + std::ptrdiff_t(k));
    }
    for (int u = 0; u < kVertices; ++u) {
      const auto got = fans.of(u);
      ASSERT_EQ(fans.size(u), int(lists[u].size())) << "step " << step << " vertex " << u;
      ASSERT_EQ(got.size(), lists[u].size());
      for (size_t k = 0; k < got.size(); ++k) {
        ASSERT_EQ(got[k].f, lists[u][k].f) << "step " << step << " vertex " << u << " corner " << k;
        ASSERT_EQ(got[k].next, lists[u][k].next);
        ASSERT_EQ(got[k].prev, lists[u][k].prev);
      }
    }
  }
  EXPECT_GT(face, 1500);
  EXPECT_EQ(most, size_t(3 * CornerFans::kInline));  // it spilled, grew and shrank there
}

// A flip undone leaves the mesh as it was, bit for bit (the defect moves try flips and
// undo most of them, and skip tries that failed before on that premise): triangle slots, every
// vertex's corners in order, the change flags and the vertices' edit times, for flips nested up to
// three deep and undone in reverse, on vertices whose corners spilled past CornerFans::kInline,
// in optimistic mode and with the intersection grid kept up to date (which then answers as the
// brute-force test).
TEST(EditMesh, AnUndoneFlipLeavesNoTrace) {
  struct State {
    std::vector<Triangle> tri;
    std::vector<bool> alive;
    std::vector<std::vector<std::array<int, 3>>> corners;
    std::vector<int64_t> changed_at;
    bool changed, connectivity_changed;
    bool operator==(const State&) const = default;
  };
  auto state_of = [](const EditMesh& m) {
    State s{{}, {}, {}, {}, m.changed(), m.connectivity_changed()};
    for (int f = 0; f < m.num_triangle_slots(); ++f) s.tri.push_back(m.tri(f)), s.alive.push_back(m.tri_alive(f));
    for (int v = 0; v < m.num_vertices(); ++v) {
      s.corners.emplace_back();
      for (const auto& c : m.corners(v)) s.corners.back().push_back({c.f, c.next, c.prev});
      s.changed_at.push_back(m.changed_at(v));
    }
    return s;
  };
  for (const bool optimistic : {true, false}) {
    SCOPED_TRACE(optimistic ? "optimistic" : "grid");
    EditMesh m(test::icosphere(2, 1.0));
    const Triangle probe = {0, 1, 2};
    if (optimistic) m.begin_optimistic();
    else m.intersects(probe, {});  // builds the grid, which the edits then keep up to date
    uint32_t rng = 11;
    auto next = [&](uint32_t n) {
      rng = rng * 1664525u + 1013904223u;
      return (rng >> 8) % n;
    };
    // A flip of a random live edge (any bend; the grid's crossing test may refuse it).
    auto random_flip = [&](EditMesh::FlipRecord& r) {
      for (int attempt = 0; attempt < 100; ++attempt) {
        const int f = int(next(uint32_t(m.num_triangle_slots())));
        if (!m.tri_alive(f)) continue;
        const int k = int(next(3)), a = m.tri(f)[k], b = m.tri(f)[(k + 1) % 3];
        const int g = m.face_with_edge(b, a);
        if (try_flip(m, a, b, f, g, m.opposite(f, a, b), m.opposite(g, b, a), -1.0, &r) ==
            FlipResult::kFlipped)
          return true;
      }
      return false;
    };
    int spilled = 0, undone = 0;
    for (int round = 0; round < 300; ++round) {
      // Kept flips now and then, so that valences drift (some past kInline).
      if (round % 3 == 0) {
        EditMesh::FlipRecord kept;
        random_flip(kept);
      }
      std::vector<State> before;
      std::vector<EditMesh::FlipRecord> records;
      const int depth = 1 + int(next(3));
      for (int d = 0; d < depth; ++d) {
        before.push_back(state_of(m));
        records.emplace_back();
        if (!random_flip(records.back())) {
          before.pop_back(), records.pop_back();
          break;
        }
      }
      while (!records.empty()) {
        m.undo_flip(records.back());
        ++undone;
        ASSERT_TRUE(state_of(m) == before.back()) << "round " << round << ", undo at depth " << records.size();
        records.pop_back(), before.pop_back();
      }
      for (int v = 0; v < m.num_vertices(); ++v) spilled += m.valence(v) > CornerFans::kInline;
      if (!optimistic && round % 10 == 0) {
        // Every live triangle is in the grid: a copy of it folds onto it (a missing one would not).
        for (int f = 0; f < m.num_triangle_slots(); ++f) {
          if (!m.tri_alive(f)) continue;
          const Triangle copy[1] = {m.tri(f)};
          ASSERT_TRUE(m.intersects_any(copy, {})) << "round " << round << " triangle " << f;
          ASSERT_TRUE(m.intersects_any_brute_force(copy, {}));
        }
      }
    }
    EXPECT_GT(undone, 500);
    EXPECT_GT(spilled, 0);
  }
}

}  // namespace
}  // namespace dsnake
