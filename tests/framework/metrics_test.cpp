// Tests of framework/metrics/metrics.h against hand-computed values: concentric circles and spheres,
// rasterised disks and balls, Dice of known overlaps, correspondence with missing targets,
// self-intersections of simple shapes, and the grid search against brute force.
#include "framework/metrics/metrics.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Geometry>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <tuple>

namespace dsnake {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Shape2 {
  PointList<2> points;
  Connectivity connectivity;
  SurfaceRef<2> ref() const { return {points, connectivity}; }
};

struct Shape3 {
  PointList<3> points;
  Connectivity connectivity;
  SurfaceRef<3> ref() const { return {points, connectivity}; }
};

// Regular n-gon of circumradius r, counter-clockwise.
Shape2 circle(int n, double r, const Point<2>& centre = Point<2>::Zero(), double phase = 0) {
  Shape2 s;
  for (int k = 0; k < n; ++k) {
    const double t = 2 * kPi * k / n + phase;
    s.points.push_back(centre + r * Point<2>(std::cos(t), std::sin(t)));
  }
  s.connectivity = Connectivity::polygon(n);
  return s;
}

Shape2 polygon(PointList<2> points) {
  Shape2 s;
  s.connectivity = Connectivity::polygon(int(points.size()));
  s.points = std::move(points);
  return s;
}

// Geodesic sphere: each icosahedron face split into f^2 triangles, vertices projected to the
// sphere of radius r (10 f^2 + 2 vertices), outward oriented.
Shape3 geodesic_sphere(int f, double r, const Point<3>& centre = Point<3>::Zero()) {
  const double phi = (1 + std::sqrt(5.0)) / 2;
  PointList<3> ico;
  for (int s1 : {-1, 1})
    for (int s2 : {-1, 1}) {
      ico.emplace_back(0, s1, s2 * phi);
      ico.emplace_back(s1, s2 * phi, 0);
      ico.emplace_back(s2 * phi, 0, s1);
    }
  std::vector<Triangle> faces;  // the 20 triples at mutual distance 2, oriented outward
  for (int i = 0; i < 12; ++i)
    for (int j = i + 1; j < 12; ++j)
      for (int k = j + 1; k < 12; ++k) {
        auto edge = [&](int a, int b) { return std::abs((ico[a] - ico[b]).norm() - 2) < 1e-9; };
        if (!edge(i, j) || !edge(j, k) || !edge(i, k)) continue;
        const bool out = (ico[j] - ico[i]).cross(ico[k] - ico[i]).dot(ico[i]) > 0;
        faces.push_back(out ? Triangle{i, j, k} : Triangle{i, k, j});
      }
  Shape3 s;
  std::map<std::tuple<int, int, int, int>, int> ids;  // canonical lattice point -> vertex
  auto vertex = [&](int a, int b, int face) {
    const auto& t = faces[face];
    const int c = f - a - b;
    // A point on an edge or corner is keyed by the edge's ordered ends, so faces agree.
    std::tuple<int, int, int, int> key;
    Point<3> x;
    auto on_edge = [&](int u, int v, int steps_from_u) {
      if (u > v) { std::swap(u, v); steps_from_u = f - steps_from_u; }
      if (steps_from_u == 0) return std::make_pair(std::make_tuple(-1, u, u, 0), ico[u]);
      if (steps_from_u == f) return std::make_pair(std::make_tuple(-1, v, v, 0), ico[v]);
      return std::make_pair(std::make_tuple(-2, u, v, steps_from_u),
                            Point<3>(ico[u] + (ico[v] - ico[u]) * double(steps_from_u) / f));
    };
    if (b == 0) std::tie(key, x) = on_edge(t[0], t[1], a);
    else if (a == 0) std::tie(key, x) = on_edge(t[0], t[2], b);
    else if (c == 0) std::tie(key, x) = on_edge(t[1], t[2], b);
    else {
      key = {face, a, b, 0};
      x = ico[t[0]] + (ico[t[1]] - ico[t[0]]) * double(a) / f + (ico[t[2]] - ico[t[0]]) * double(b) / f;
    }
    auto [it, added] = ids.try_emplace(key, int(s.points.size()));
    if (added) s.points.push_back(centre + r * x.normalized());
    return it->second;
  };
  std::vector<Triangle> tris;
  for (int face = 0; face < 20; ++face)
    for (int a = 0; a < f; ++a)
      for (int b = 0; a + b < f; ++b) {
        tris.push_back({vertex(a, b, face), vertex(a + 1, b, face), vertex(a, b + 1, face)});
        if (a + b + 1 < f)
          tris.push_back({vertex(a + 1, b, face), vertex(a + 1, b + 1, face), vertex(a, b + 1, face)});
      }
  s.connectivity = Connectivity::mesh(int(s.points.size()), std::move(tris));
  return s;
}

// Brute-force reference distances, written independently of the library: closest point on a
// segment by projection, on a triangle by barycentric coordinates from the normal equations.
template <int D>
double brute_segment(const Point<D>& p, const Point<D>& a, const Point<D>& b) {
  const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
  return (a + t * (b - a) - p).norm();
}

double brute_triangle(const Point<3>& p, const Point<3>& a, const Point<3>& b, const Point<3>& c) {
  const Point<3> u = b - a, v = c - a, w = p - a;
  const double uu = u.dot(u), uv = u.dot(v), vv = v.dot(v), wu = w.dot(u), wv = w.dot(v);
  const double det = uu * vv - uv * uv;
  const double s = (vv * wu - uv * wv) / det, t = (uu * wv - uv * wu) / det;
  if (s >= 0 && t >= 0 && s + t <= 1) return (a + s * u + t * v - p).norm();
  return std::min({brute_segment<3>(p, a, b), brute_segment<3>(p, b, c), brute_segment<3>(p, c, a)});
}

double brute_distance(const Shape2& s, const Point<2>& p) {
  double d = INFINITY;
  const size_t n = s.points.size();
  for (size_t i = 0; i < n; ++i) d = std::min(d, brute_segment<2>(p, s.points[i], s.points[(i + 1) % n]));
  return d;
}

double brute_distance(const Shape3& s, const Point<3>& p) {
  double d = INFINITY;
  for (const auto& t : s.connectivity.triangles())
    d = std::min(d, brute_triangle(p, s.points[t[0]], s.points[t[1]], s.points[t[2]]));
  return d;
}

int count_inside(const Image<2>& img) { return int(std::count(img.data().begin(), img.data().end(), 1.0f)); }
int count_inside(const Image<3>& img) { return int(std::count(img.data().begin(), img.data().end(), 1.0f)); }

template <int D>
Grid<D> make_grid(const GridIndex<D>& size, const Point<D>& spacing, const Point<D>& origin) {
  Grid<D> g;
  g.size = size;
  g.spacing = spacing;
  g.origin = origin;
  return g;
}

TEST(Metrics, ConcentricCirclesGiveRadiusDifference) {
  const Shape2 inner = circle(400, 10), outer = circle(400, 12);
  const SurfaceDistances d = surface_distances<2>(inner.ref(), outer.ref(), 0.05);
  // Every point of either 400-gon is within r (1 - cos(pi / 400)) < 4e-4 of its circle.
  EXPECT_NEAR(d.mean, 2.0, 1e-3);
  EXPECT_NEAR(d.hausdorff95, 2.0, 1e-3);
  EXPECT_NEAR(d.hausdorff, 2.0, 1e-3);
  EXPECT_LE(d.hausdorff95, d.hausdorff);
}

TEST(Metrics, ConcentricSpheresGiveRadiusDifference) {
  const Shape3 inner = geodesic_sphere(16, 10), outer = geodesic_sphere(16, 11);
  ASSERT_EQ(inner.points.size(), 2562u);
  // Chord error: the mesh of radius r lies between r - delta and r, where r - delta is the
  // least distance from the centre to a triangle. So every distance is in [1 - d11, 1 + d10].
  auto chord = [](const Shape3& s, double r) {
    return r - brute_distance(s, Point<3>::Zero());
  };
  const double d10 = chord(inner, 10), d11 = chord(outer, 11);
  EXPECT_GT(d10, 0);
  EXPECT_LT(d10, 0.05);
  const SurfaceDistances d = surface_distances<3>(inner.ref(), outer.ref(), 0.4);
  for (double v : {d.mean, d.hausdorff95, d.hausdorff}) {
    EXPECT_GE(v, 1 - d11 - 1e-12);
    EXPECT_LE(v, 1 + d10 + 1e-12);
  }
  EXPECT_NEAR(d.mean, 1.0, 0.02);
}

// A collapsed snake far inside the truth (the case of a failed run): the truth's samples lie
// farther from the tiny surface's grid than the grid is large, which takes the facet tree;
// the distances must still be the radius difference (within the chord errors).
TEST(Metrics, ATinySurfaceFarFromTheOtherGivesTheRadiusDifference) {
  const Shape3 tiny = geodesic_sphere(16, 0.05), outer = geodesic_sphere(16, 11);
  const double d11 = 11 - brute_distance(outer, Point<3>::Zero());
  const SurfaceDistances d = surface_distances<3>(tiny.ref(), outer.ref(), 0.4);
  for (double v : {d.mean, d.hausdorff95, d.hausdorff}) {
    EXPECT_GE(v, 10.95 - d11 - 1e-9);
    EXPECT_LE(v, 10.95 + 0.05 + 1e-9);
  }
  // and the search agrees with brute force from far away and from near by
  const PointList<3> q = {Point<3>(40, -3, 2), Point<3>(0.3, 0.2, -0.1), Point<3>(-25, 30, 12), Point<3>(0, 0, 0.06)};
  const std::vector<double> dq = distances_to_surface<3>(tiny.ref(), q);
  for (size_t i = 0; i < q.size(); ++i) EXPECT_NEAR(dq[i], brute_distance(tiny, q[i]), 1e-12) << i;
}

TEST(Metrics, ShapeAgainstItselfIsZero) {
  const Shape2 c = circle(37, 5, Point<2>(3, -2));
  const SurfaceDistances d2 = surface_distances<2>(c.ref(), c.ref(), 0.1);
  EXPECT_NEAR(d2.hausdorff, 0.0, 1e-12);
  const Shape3 s = geodesic_sphere(4, 7, Point<3>(1, 2, 3));
  const SurfaceDistances d3 = surface_distances<3>(s.ref(), s.ref(), 0.2);
  EXPECT_NEAR(d3.mean, 0.0, 1e-12);
  EXPECT_NEAR(d3.hausdorff95, 0.0, 1e-12);
  EXPECT_NEAR(d3.hausdorff, 0.0, 1e-12);
}

TEST(Metrics, DiceOfMaskWithItselfIsOne) {
  const auto grid = make_grid<2>({30, 20}, {1, 1}, {0, 0});
  const Image<2> disk = rasterize_interior<2>(circle(50, 8, Point<2>(15, 10)).ref(), grid);
  ASSERT_GT(count_inside(disk), 0);
  EXPECT_EQ(dice<2>(disk, disk), 1.0);
  EXPECT_EQ(dice<2>(Image<2>(grid), Image<2>(grid)), 1.0);  // both empty
  EXPECT_EQ(dice<2>(disk, Image<2>(grid)), 0.0);
}

TEST(Metrics, HalfOverlappingSquaresGiveHalfDice) {
  // Voxel centres 2..11 x 2..11 (100 voxels) and 7..16 x 2..11 (100): 50 in common.
  const auto grid = make_grid<2>({20, 20}, {1, 1}, {0, 0});
  const Shape2 a = polygon({{1.5, 1.5}, {11.5, 1.5}, {11.5, 11.5}, {1.5, 11.5}});
  const Shape2 b = polygon({{6.5, 1.5}, {6.5, 11.5}, {16.5, 11.5}, {16.5, 1.5}});  // clockwise
  const Image<2> ma = rasterize_interior<2>(a.ref(), grid), mb = rasterize_interior<2>(b.ref(), grid);
  EXPECT_EQ(count_inside(ma), 100);
  EXPECT_EQ(count_inside(mb), 100);
  EXPECT_DOUBLE_EQ(dice<2>(ma, mb), 2.0 * 50 / 200);
}

TEST(Metrics, RasterizedDiskMatchesArea) {
  for (const Point<2>& spacing : {Point<2>(1, 1), Point<2>(0.7, 1.3)}) {
    const auto grid = make_grid<2>({80, 60}, spacing, {-30.3, -37.9});
    const double r = 20;
    const Image<2> disk = rasterize_interior<2>(circle(720, r, Point<2>(0.2, 0.1)).ref(), grid);
    const double area = count_inside(disk) * spacing.prod();
    EXPECT_NEAR(area / (kPi * r * r), 1.0, 0.02) << spacing.transpose();
  }
}

TEST(Metrics, RasterizedSphereMatchesVolume) {
  const double r = 12;
  const Shape3 s = geodesic_sphere(16, r, Point<3>(0.3, -0.2, 0.1));
  for (const Point<3>& spacing : {Point<3>(1, 1, 1), Point<3>(1, 1, 2.5)}) {
    const GridIndex<3> size(30, 30, int(std::ceil(30 / spacing.z())));
    const auto grid = make_grid<3>(size, spacing, -0.5 * (size.cast<double>() - Point<3>::Ones()).cwiseProduct(spacing));
    const Image<3> ball = rasterize_interior<3>(s.ref(), grid);
    const double volume = count_inside(ball) * spacing.prod();
    EXPECT_NEAR(volume / (4.0 / 3.0 * kPi * r * r * r), 1.0, 0.02) << spacing.transpose();
  }
}

TEST(Metrics, RaysThroughVerticesAndEdgesCountOnce) {
  // An octahedron |x| + |y| + |z| <= 3 with its vertices and edges on rows of voxel centres:
  // rays through vertices and edges must count once, or whole rows would flip.
  const auto grid = make_grid<3>({9, 9, 9}, {1, 1, 1}, {-4, -4, -4});
  Shape3 octa;
  octa.points = {{3, 0, 0}, {-3, 0, 0}, {0, 3, 0}, {0, -3, 0}, {0, 0, 3}, {0, 0, -3}};
  octa.connectivity = Connectivity::mesh(6, {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                             {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}});
  ASSERT_EQ(octa.connectivity.closed_manifold_problem(), "");
  const Image<3> m = rasterize_interior<3>(octa.ref(), grid);
  // Centres with |x| + |y| + |z| < 3 are inside, > 3 outside; those on the surface go either way.
  for (int64_t l = 0; l < m.num_voxels(); ++l) {
    const GridIndex<3> i = grid.index(l);
    const int sum = std::abs(i.x() - 4) + std::abs(i.y() - 4) + std::abs(i.z() - 4);
    if (sum < 3) {
      EXPECT_EQ(m[l], 1.0f) << i.transpose();
    } else if (sum > 3) {
      EXPECT_EQ(m[l], 0.0f) << i.transpose();
    }
  }
}

TEST(Metrics, RegisteredMaskGivesDiceOne) {
  const Shape3 s = geodesic_sphere(10, 9, Point<3>(16.2, 15.7, 15.9));
  GroundTruth<3> truth;
  truth.mask = rasterize_interior<3>(s.ref(), make_grid<3>({32, 32, 16}, {1, 1, 2}, {0, 0, 0}));
  std::vector<int> ids(s.points.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = int(i);
  const Snake<3> snake(s.points, s.connectivity, ids);
  const Metrics m = compute_metrics<3>(snake, truth);
  ASSERT_TRUE(m.dice.has_value());
  EXPECT_EQ(*m.dice, 1.0);
  ASSERT_TRUE(m.mean_surface_distance.has_value());
  EXPECT_LT(*m.mean_surface_distance, 0.5);  // staircase vs smooth surface, voxels 1 x 1 x 2
  EXPECT_LT(*m.hausdorff, 1.5);
  EXPECT_FALSE(m.correspondence_error_mean.has_value());
  EXPECT_EQ(m.self_intersections, 0);
}

TEST(Metrics, CircleAgainstItsRasterisationIsWithinHalfVoxel) {
  const Shape2 c = circle(500, 20, Point<2>(25.3, 24.6));
  const Image<2> mask = rasterize_interior<2>(c.ref(), make_grid<2>({51, 51}, {1, 1}, {0, 0}));
  const SurfaceDistances d = surface_distances_to_mask<2>(c.ref(), mask, 0.1);
  EXPECT_GT(d.mean, 0.05);
  EXPECT_LT(d.mean, 0.5);
  EXPECT_LT(d.hausdorff, 1.0);
  // compute_metrics picks the mask boundary when there is no surface.
  GroundTruth<2> truth;
  truth.mask = mask;
  const Metrics m = compute_metrics<2>(Snake<2>(c.points, c.connectivity, std::vector<int>(500, -1)), truth);
  EXPECT_LT(*m.mean_surface_distance, 0.5);
  EXPECT_EQ(*m.dice, 1.0);
}

TEST(Metrics, ComputeMetricsUsesSurfaceWhenGiven) {
  const Shape2 inner = circle(400, 10), outer = circle(400, 12);
  GroundTruth<2> truth;
  truth.surface = Template<2>{outer.points, outer.connectivity, {}};
  const Metrics m = compute_metrics<2>(Snake<2>(inner.points, inner.connectivity, std::vector<int>(400, -1)), truth);
  EXPECT_NEAR(*m.mean_surface_distance, 2.0, 1e-3);
  EXPECT_NEAR(*m.hausdorff95, 2.0, 1e-3);
  EXPECT_FALSE(m.dice.has_value());
  EXPECT_FALSE(m.correspondence_error_max.has_value());
}

TEST(Metrics, CorrespondenceErrorSkipsNullTargetsAndFreeVertices) {
  // Snake vertices 0..4 carry template ids 0, -1 (free), 1, 2, 3.
  const PointList<2> q = {{0, 0}, {5, 0}, {10, 0}, {10, 10}, {0, 10}};
  const Snake<2> snake(q, Connectivity::polygon(5), {0, -1, 1, 2, 3});
  std::vector<std::optional<Point<2>>> targets = {Point<2>(3, 4), std::nullopt, Point<2>(10, 11),
                                                  Point<2>(0, 10), Point<2>(1, 1)};  // id 4: no vertex
  const CorrespondenceError e = correspondence_error<2>(snake, targets);
  EXPECT_EQ(e.count, 3);
  EXPECT_DOUBLE_EQ(e.mean, (5.0 + 1.0 + 0.0) / 3);
  EXPECT_DOUBLE_EQ(e.max, 5.0);
  ASSERT_EQ(e.per_vertex.size(), 5u);
  EXPECT_DOUBLE_EQ(e.per_vertex[0], 5.0);
  EXPECT_TRUE(std::isnan(e.per_vertex[1]));
  EXPECT_DOUBLE_EQ(e.per_vertex[2], 1.0);
  EXPECT_TRUE(std::isnan(e.per_vertex[4]));
  GroundTruth<2> truth;
  truth.targets = targets;
  const Metrics m = compute_metrics<2>(snake, truth);
  EXPECT_DOUBLE_EQ(*m.correspondence_error_mean, 2.0);
  EXPECT_DOUBLE_EQ(*m.correspondence_error_max, 5.0);
  EXPECT_FALSE(m.mean_surface_distance.has_value());
}

TEST(Metrics, FigureEightHasOneSelfIntersection) {
  EXPECT_EQ(count_self_intersections<2>(polygon({{0, 0}, {2, 2}, {2, 0}, {0, 2}}).ref()), 1);
  EXPECT_EQ(count_self_intersections<2>(circle(200, 5).ref()), 0);
  EXPECT_EQ(count_self_intersections<2>(polygon({{0, 0}, {4, 0}, {4, 4}, {0, 4}}).ref()), 0);
  // Touching counts: vertex 3 lies on the non-adjacent edge (0, 1).
  EXPECT_EQ(count_self_intersections<2>(polygon({{0, 0}, {4, 0}, {4, 4}, {2, 0}}).ref()), 1);
}

TEST(Metrics, SphereSelfIntersectionsAppearWhenAVertexIsPulledThrough) {
  Shape3 s = geodesic_sphere(8, 10);
  EXPECT_EQ(count_self_intersections<3>(s.ref()), 0);
  s.points[0] = -1.5 * s.points[0];  // through the centre and out of the opposite side
  EXPECT_GT(count_self_intersections<3>(s.ref()), 0);
}

TEST(Metrics, GridSearchAgreesWithBruteForce) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  // 2D: a random star polygon; 3D: a randomly bumped small geodesic sphere.
  Shape2 star;
  for (int k = 0; k < 40; ++k) {
    const double t = 2 * kPi * k / 40, r = 6 + 3 * unit(rng);
    star.points.emplace_back(r * std::cos(t) + 1, r * std::sin(t) - 2);
  }
  star.connectivity = Connectivity::polygon(40);
  Shape3 blob = geodesic_sphere(3, 5, Point<3>(2, -1, 0.5));
  for (auto& p : blob.points) p += 0.8 * Point<3>(unit(rng), unit(rng), unit(rng));
  PointList<2> q2;
  PointList<3> q3;
  for (int i = 0; i < 1500; ++i) {
    const double scale = i < 1000 ? 10 : 60;  // near the shapes, then far outside their grids
    q2.push_back(scale * Point<2>(unit(rng), unit(rng)));
    q3.push_back(scale * Point<3>(unit(rng), unit(rng), unit(rng)));
  }
  for (const auto& p : star.points) q2.push_back(p);
  for (const auto& p : blob.points) q3.push_back(p + Point<3>(0.01, 0, 0));
  const std::vector<double> d2 = distances_to_surface<2>(star.ref(), q2);
  const std::vector<double> d3 = distances_to_surface<3>(blob.ref(), q3);
  double err2 = 0, err3 = 0;
  for (size_t i = 0; i < q2.size(); ++i) err2 = std::max(err2, std::abs(d2[i] - brute_distance(star, q2[i])));
  for (size_t i = 0; i < q3.size(); ++i) err3 = std::max(err3, std::abs(d3[i] - brute_distance(blob, q3[i])));
  EXPECT_LT(err2, 1e-12);
  EXPECT_LT(err3, 1e-12);
}

// Points many cells away from every facet of a fine surface (deep inside it) and batches whose
// candidate box would span most of the grid go to the facet tree (a collapsed snake's
// metrics would walk O((distance / cell)^3) empty cells); the distances stay exact.
TEST(Metrics, TreeQueriesFarFromEveryFacetAgreeWithBruteForce) {
  const Shape3 fine = geodesic_sphere(24, 50, Point<3>(3, -2, 1));
  ASSERT_GT(fine.points.size(), 5000u);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  PointList<3> q;
  for (int i = 0; i < 300; ++i) q.push_back(Point<3>(3, -2, 1) + 25 * Point<3>(unit(rng), unit(rng), unit(rng)));
  for (int i = 0; i < 100; ++i) q.push_back(400 * Point<3>(unit(rng), unit(rng), unit(rng)));
  const std::vector<double> d = distances_to_surface<3>(fine.ref(), q);
  double err = 0;
  for (size_t i = 0; i < q.size(); ++i) err = std::max(err, std::abs(d[i] - brute_distance(fine, q[i])));
  EXPECT_LT(err, 1e-12);
  // A small sphere at the centre against the fine one: every distance is the radius difference
  // within the chord errors, in both directions (the small sphere's batches query far).
  const Shape3 small = geodesic_sphere(8, 2, Point<3>(3, -2, 1));
  const double chord50 = 50 - brute_distance(fine, Point<3>(3, -2, 1));
  const double chord2 = 2 - brute_distance(small, Point<3>(3, -2, 1));
  const SurfaceDistances sd = surface_distances<3>(small.ref(), fine.ref(), 0.5);
  for (double v : {sd.mean, sd.hausdorff95, sd.hausdorff}) {
    EXPECT_GE(v, 48 - chord50 - 1e-9);
    EXPECT_LE(v, 48 + chord2 + 1e-9);
  }
}

TEST(Metrics, ResultsDoNotDependOnThreadCount) {
  const Shape3 a = geodesic_sphere(6, 20, Point<3>(40, 40, 40));
  const Shape3 b = geodesic_sphere(7, 21, Point<3>(40.5, 39.7, 40.2));
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const SurfaceDistances one = surface_distances<3>(a.ref(), b.ref(), 0.6);
  const int si_one = count_self_intersections<3>(a.ref());
  omp_set_num_threads(2);
  const SurfaceDistances two = surface_distances<3>(a.ref(), b.ref(), 0.6);
  const int si_two = count_self_intersections<3>(a.ref());
  omp_set_num_threads(threads);
  EXPECT_EQ(one.mean, two.mean);
  EXPECT_EQ(one.hausdorff95, two.hausdorff95);
  EXPECT_EQ(one.hausdorff, two.hausdorff);
  EXPECT_EQ(si_one, si_two);
}

// Offset spheres: the distance from b to a lies in [R_b - R_a - |c|, R_b - R_a + |c|] pointwise.
// (Their speed at 7000 vertices is measured in experiments/bench/bench_metrics.)
TEST(Metrics, OffsetSpheresHaveBoundedDistances) {
  const Shape3 a = geodesic_sphere(16, 30, Point<3>(40, 40, 40));
  const Shape3 b = geodesic_sphere(17, 31.5, Point<3>(40.8, 39.5, 40.3));
  const SurfaceDistances d = surface_distances<3>(a.ref(), b.ref(), 0.5);
  EXPECT_EQ(count_self_intersections<3>(b.ref()), 0);
  // The centres are 0.98 apart and the radii differ by 1.5: every distance lies in [0.52, 2.48]
  // (plus the chord error of the meshes).
  EXPECT_GT(d.mean, 1.0);
  EXPECT_LT(d.mean, 2.0);
  EXPECT_LT(d.hausdorff, 2.6);
  EXPECT_GT(d.hausdorff95, 0.52);
}

}  // namespace
}  // namespace dsnake

namespace dsnake {
namespace {

// Dice on the box of the two objects' voxels equals Dice on the whole grid, for a
// shape inside, across the border of and outside the grid.
TEST(MetricsBoundedCost, DiceOnTheObjectsBoxEqualsDiceOnTheWholeGrid) {
  const auto grid = make_grid<2>({60, 50}, {0.7, 1.3}, {-3, 2});
  const Image<2> truth = rasterize_interior<2>(circle(90, 9, Point<2>(15, 30)).ref(), grid);
  for (const Point<2>& c : {Point<2>(17, 31), Point<2>(-4, 20), Point<2>(200, 200)}) {
    const Shape2 s = circle(70, 8, c);
    EXPECT_EQ(dice_against_mask<2>(s.ref(), truth), dice<2>(rasterize_interior<2>(s.ref(), grid), truth)) << c.transpose();
  }
}

// The sample cap: the spacing grows only when the count at the finest exceeds the cap, and then
// to the smallest spacing (within 1e-3) that fits; the distances of two circles 2 apart stay 2.
TEST(MetricsBoundedCost, TheSampleCapCoarsensTheSpacingJustEnough) {
  auto count = [](double h) { return int64_t(std::ceil(100.0 / h)); };
  EXPECT_EQ(bounded_spacing(0.1, 100.0, 2000, count), 0.1);
  const double h = bounded_spacing(0.1, 100.0, 500, count);
  EXPECT_LE(count(h), 500);
  EXPECT_GT(count(h / 1.002), 500);
  EXPECT_EQ(bounded_spacing(0.1, 1.0, 10, count), 1.0);  // even one sample per facet is too many
  const Shape2 inner = circle(400, 10), outer = circle(400, 12);
  const SurfaceDistances capped = surface_distances<2>(inner.ref(), outer.ref(), 0.01, 2000);
  EXPECT_NEAR(capped.mean, 2.0, 1e-3);
  EXPECT_NEAR(capped.hausdorff, 2.0, 1e-3);
}

}  // namespace
}  // namespace dsnake
