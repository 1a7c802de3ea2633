// Potentials for the global solve: the least-squares integration recovers known potentials and
// solves its normal equations; the GVF potential of a disk/sphere is lowest on the boundary;
// edge and distance potentials match their definitions; the smooth interpolation reproduces
// quadratics (cubic) and linear functions (linear), matches the Catmull-Rom kernel and has
// derivatives consistent with its values (finite differences and Ceres' GradientChecker).
#include "fields/smooth_potential.h"

#include "fields/distance.h"
#include "fields/edge_map.h"
#include "fields/gradient.h"
#include "fields/gvf.h"
#include "framework/core/errors.h"
#include "framework/core/json_reader.h"

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

namespace dsnake {
namespace {

template <int D>
Grid<D> make_grid(const GridIndex<D>& size, const Point<D>& spacing, const Point<D>& origin) {
  Grid<D> g;
  g.size = size;
  g.spacing = spacing;
  g.origin = origin;
  return g;
}

// F = -grad P sampled at the voxel centres, for an analytic P with gradient `grad`.
template <int D>
VectorField<D> sampled_force(const Grid<D>& grid, const std::function<Point<D>(const Point<D>&)>& grad) {
  VectorField<D> f(grid);
  for (int64_t l = 0; l < grid.num_voxels(); ++l) f[l] = -grad(grid.to_physical(grid.index(l)));
  return f;
}

// max |(p - mean p) - (q - mean q)|: equality up to a constant.
double max_diff_up_to_constant(const std::vector<double>& p, const std::vector<double>& q) {
  double mp = 0, mq = 0;
  for (size_t i = 0; i < p.size(); ++i) mp += p[i], mq += q[i];
  mp /= p.size();
  mq /= q.size();
  double worst = 0;
  for (size_t i = 0; i < p.size(); ++i) worst = std::max(worst, std::abs((p[i] - mp) - (q[i] - mq)));
  return worst;
}

// Visits every grid edge (i, j = i + e_a) with its axis.
template <int D>
void for_each_edge(const Grid<D>& grid, const std::function<void(int64_t, int64_t, int)>& visit) {
  for (int64_t i = 0; i < grid.num_voxels(); ++i) {
    const GridIndex<D> idx = grid.index(i);
    for (int a = 0; a < D; ++a) {
      if (idx[a] + 1 >= grid.size[a]) continue;
      GridIndex<D> next = idx;
      next[a] += 1;
      visit(i, grid.linear(next), a);
    }
  }
}

// Checks the integration on an analytic potential: returns max error up to a constant.
template <int D>
double integration_error(const Grid<D>& grid, const std::function<double(const Point<D>&)>& potential,
                         const std::function<Point<D>(const Point<D>&)>& grad, double* range) {
  const std::vector<double> p = integrate_field(sampled_force<D>(grid, grad));
  std::vector<double> truth(grid.num_voxels());
  for (int64_t l = 0; l < grid.num_voxels(); ++l) truth[l] = potential(grid.to_physical(grid.index(l)));
  *range = *std::max_element(truth.begin(), truth.end()) - *std::min_element(truth.begin(), truth.end());
  EXPECT_EQ(*std::min_element(p.begin(), p.end()), 0.0);
  return max_diff_up_to_constant(p, truth);
}

TEST(IntegrateField, RecoversQuadraticExactly2dAnisotropic) {
  // The averaged edge force is the exact mean slope of a quadratic: the residuals are zero.
  const Grid<2> grid = make_grid<2>(GridIndex<2>(40, 30), Point<2>(0.7, 1.3), Point<2>(-5, 3));
  auto p = [](const Point<2>& x) { return 0.3 * x[0] * x[0] - 0.2 * x[0] * x[1] + 0.1 * x[1] * x[1] + x[0]; };
  auto g = [](const Point<2>& x) { return Point<2>(0.6 * x[0] - 0.2 * x[1] + 1, -0.2 * x[0] + 0.2 * x[1]); };
  double range;
  const double err = integration_error<2>(grid, p, g, &range);
  // Exact up to the rounding of the stored vectors to float: ~1e-8 of the range (1e-9 with
  // vectors stored in double).
  EXPECT_LT(err, 2e-8 * range) << range;
}

TEST(IntegrateField, RecoversQuadraticExactly3dAnisotropic) {
  const Grid<3> grid = make_grid<3>(GridIndex<3>(20, 17, 12), Point<3>(1, 1, 2.5), Point<3>(2, -1, 0.5));
  auto p = [](const Point<3>& x) { return 0.3 * x[0] * x[0] + 0.05 * x[1] * x[2] - 0.1 * x[2] * x[2] + 2 * x[1]; };
  auto g = [](const Point<3>& x) { return Point<3>(0.6 * x[0], 0.05 * x[2] + 2, 0.05 * x[1] - 0.2 * x[2]); };
  double range;
  const double err = integration_error<3>(grid, p, g, &range);
  EXPECT_LT(err, 2e-8 * range) << range;  // float-rounded vectors, as above
}

// Error (up to a constant) of the integrated Gaussian bump 5 exp(-|x - c|^2 / 72) on `grid`.
template <int D>
double gaussian_bump_error(const Grid<D>& grid, const Point<D>& c, double* range) {
  auto p = [&](const Point<D>& x) { return 5 * std::exp(-(x - c).squaredNorm() / 72.0); };
  auto d = [&](const Point<D>& x) -> Point<D> { return -p(x) * (x - c) / 36.0; };
  return integration_error<D>(grid, p, d, range);
}

TEST(IntegrateField, RecoversGaussianBumpToSecondOrder) {
  // The edge average of the force is the trapezoid rule: the error is O(h^2), so halving the
  // spacing (same physical box) divides it by ~4.
  double range;
  const double e2 = gaussian_bump_error<2>(make_grid<2>(GridIndex<2>(48, 40), Point<2>(0.8, 1.1), Point<2>(0, 0)),
                                           Point<2>(20, 21), &range);
  const double e2_fine = gaussian_bump_error<2>(make_grid<2>(GridIndex<2>(96, 80), Point<2>(0.4, 0.55), Point<2>(0, 0)),
                                                Point<2>(20, 21), &range);
  EXPECT_GT(range, 4.5);
  EXPECT_LT(e2, 5e-3 * range) << e2;
  EXPECT_LT(e2_fine, e2 / 3.5) << e2 << " " << e2_fine;

  const double e3 = gaussian_bump_error<3>(make_grid<3>(GridIndex<3>(30, 28, 14), Point<3>(1, 1, 2.5), Point<3>(0, 0, 0)),
                                           Point<3>(14, 15, 16), &range);
  const double e3_fine = gaussian_bump_error<3>(
      make_grid<3>(GridIndex<3>(60, 56, 28), Point<3>(0.5, 0.5, 1.25), Point<3>(0, 0, 0)), Point<3>(14, 15, 16), &range);
  EXPECT_LT(e3, 1.5e-2 * range) << e3;
  EXPECT_LT(e3_fine, e3 / 3.5) << e3 << " " << e3_fine;
}

TEST(IntegrateField, SolvesTheNeumannNormalEquations) {
  // A field with curl and noise (not a gradient): L P = D^T g must hold exactly, with L and
  // D^T g assembled here edge by edge.
  const Grid<3> grid = make_grid<3>(GridIndex<3>(17, 12, 9), Point<3>(1, 0.8, 2.5), Point<3>(0, 0, 0));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> noise(-1, 1);
  VectorField<3> f(grid);
  for (int64_t l = 0; l < grid.num_voxels(); ++l) {
    const Point<3> x = grid.to_physical(grid.index(l));
    f[l] = Point<3>(-x[1] + noise(rng), x[0] + noise(rng), 0.3 * x[0] + noise(rng));
  }
  const std::vector<double> p = integrate_field(f);
  const VectorField<3>& stored = f;  // the stored vectors, read in double as the solver reads them
  std::vector<double> lp(p.size(), 0.0), b(p.size(), 0.0);
  for_each_edge<3>(grid, [&](int64_t i, int64_t j, int a) {
    const double h = grid.spacing[a];
    const double d = (p[j] - p[i]) / h, g = -(stored[i][a] + stored[j][a]) / 2;
    lp[i] -= d / h;
    lp[j] += d / h;
    b[i] -= g / h;
    b[j] += g / h;
  });
  double worst = 0, scale = 0;
  for (size_t l = 0; l < p.size(); ++l) {
    worst = std::max(worst, std::abs(lp[l] - b[l]));
    scale = std::max(scale, std::abs(b[l]));
  }
  EXPECT_GT(scale, 0.5);
  EXPECT_LT(worst, 1e-8 * scale) << worst;
}

TEST(IntegrateField, SingleVoxelAxisAndDeterministicForThreadCounts) {
  // An axis of one voxel has no edges: the 3D solve equals the 2D one.
  const Grid<2> g2 = make_grid<2>(GridIndex<2>(13, 9), Point<2>(1.5, 1), Point<2>(0, 0));
  const Grid<3> g3 = make_grid<3>(GridIndex<3>(13, 9, 1), Point<3>(1.5, 1, 2), Point<3>(0, 0, 0));
  VectorField<2> f2(g2);
  VectorField<3> f3(g3);
  for (int64_t l = 0; l < g2.num_voxels(); ++l) {
    f2[l] = Point<2>(std::sin(0.3 * l), std::cos(0.7 * l));
    f3[l] = Point<3>(f2[l][0], f2[l][1], 5.0);
  }
  const std::vector<double> p2 = integrate_field(f2), p3 = integrate_field(f3);
  for (size_t l = 0; l < p2.size(); ++l) EXPECT_NEAR(p2[l], p3[l], 1e-12);

  const Grid<3> grid = make_grid<3>(GridIndex<3>(37, 23, 19), Point<3>(1, 1, 2.5), Point<3>(0, 0, 0));
  VectorField<3> f(grid);
  for (int64_t l = 0; l < grid.num_voxels(); ++l) f[l] = Point<3>(std::sin(0.01 * l), std::cos(0.02 * l), 0.1);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const std::vector<double> one = integrate_field(f);
  omp_set_num_threads(2);
  const std::vector<double> two = integrate_field(f);
  omp_set_num_threads(threads);
  EXPECT_TRUE(one == two);
}

// A binary disk / ball image of radius r about c (physical units).
template <int D>
Image<D> ball_image(const Grid<D>& grid, const Point<D>& c, double r) {
  Image<D> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l) image[l] = (grid.to_physical(grid.index(l)) - c).norm() < r ? 1.0f : 0.0f;
  return image;
}

// The integrated GVF potential is a valley along the boundary: its argmin voxel lies on it.
template <int D>
void expect_gvf_potential_minimum_on_boundary(const Grid<D>& grid, const Point<D>& c, double r) {
  const Image<D> image = ball_image(grid, c, r);
  GvfField<D> gvf;
  gvf.compute(image);
  PotentialOptions o;
  o.type = PotentialType::kIntegrated;
  const Image<D> p = compute_potential(o, image, &gvf);
  const auto it = std::min_element(p.data().begin(), p.data().end());
  EXPECT_EQ(*it, 0.0f);
  const Point<D> x = grid.to_physical(grid.index(it - p.data().begin()));
  EXPECT_LT(std::abs((x - c).norm() - r), 1.5) << x.transpose();
  // The centre and the corner are higher than the whole boundary ring.
  double ring_max = 0;
  for (int64_t l = 0; l < p.num_voxels(); ++l)
    if (std::abs((grid.to_physical(grid.index(l)) - c).norm() - r) < 0.5) ring_max = std::max(ring_max, double(p[l]));
  const double centre = p.at(((c - grid.origin).array() / grid.spacing.array()).round().template cast<int>().matrix());
  EXPECT_GT(centre, ring_max);
  EXPECT_GT(p[0], ring_max);
}

TEST(ComputePotential, IntegratedGvfMinimumOnDiskAndSphere) {
  expect_gvf_potential_minimum_on_boundary<2>(make_grid<2>(GridIndex<2>(64, 64), Point<2>(1, 1), Point<2>(0, 0)),
                                              Point<2>(31.7, 32.2), 18.0);
  expect_gvf_potential_minimum_on_boundary<3>(make_grid<3>(GridIndex<3>(32, 32, 32), Point<3>(1, 1, 1), Point<3>(0, 0, 0)),
                                              Point<3>(15.6, 16.3, 15.8), 9.0);
}

TEST(ComputePotential, EdgeIsMaxMinusEdgeMap) {
  // Hand-computed: I = x^2 on 5 voxels, no smoothing. Central differences inside, one-sided at
  // the ends: grad = 1, 2, 4, 6, 7; f = 1, 4, 16, 36, 49; P = 1 - f / 49.
  const Grid<2> line = make_grid<2>(GridIndex<2>(5, 1), Point<2>(1, 1), Point<2>(0, 0));
  Image<2> ramp(line);
  for (int i = 0; i < 5; ++i) ramp[i] = float(i * i);
  PotentialOptions o;
  o.type = PotentialType::kEdge;
  o.sigma = 0;
  const Image<2> p = compute_potential<2>(o, ramp, nullptr);
  const double expected[5] = {48 / 49.0, 45 / 49.0, 33 / 49.0, 13 / 49.0, 0};
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(p[i], expected[i], 1e-6) << i;

  // A disk: exactly max f - f of the normalised edge map, and the gradient field's potential.
  const Grid<2> grid = make_grid<2>(GridIndex<2>(40, 36), Point<2>(1, 1.2), Point<2>(0, 0));
  const Image<2> image = ball_image<2>(grid, Point<2>(19.5, 21), 10);
  o.sigma = 1.5;
  const Image<2> pd = compute_potential<2>(o, image, nullptr);
  const EdgeMap<2> edges = compute_edge_map(image, EdgeMapOptions{1.5, true}, false, "test");
  const float f_max = *std::max_element(edges.f.begin(), edges.f.end());
  GradientField<2> gradient(GradientFieldOptions{1.5, true});
  gradient.compute(image);
  for (int64_t l = 0; l < pd.num_voxels(); ++l) {
    ASSERT_EQ(pd[l], f_max - edges.f[l]) << l;
    ASSERT_NEAR(pd[l], gradient.potential(grid.to_physical(grid.index(l))), 1e-6) << l;
  }
  EXPECT_EQ(*std::min_element(pd.data().begin(), pd.data().end()), 0.0f);
}

TEST(ComputePotential, DistanceIsZeroOnEdgesAndDistanceElsewhere) {
  const Grid<3> grid = make_grid<3>(GridIndex<3>(20, 18, 10), Point<3>(1, 1, 2.5), Point<3>(0, 0, 0));
  const Image<3> image = ball_image<3>(grid, Point<3>(9.5, 8.7, 11.0), 6.0);
  PotentialOptions o;
  o.type = PotentialType::kDistance;
  o.sigma = 1.0;
  const Image<3> p = compute_potential<3>(o, image, nullptr);
  const EdgeMap<3> edges = compute_edge_map(image, EdgeMapOptions{1.0, true}, false, "test");
  std::vector<int64_t> edge_voxels;
  for (int64_t l = 0; l < p.num_voxels(); ++l)
    if (edges.f[l] >= 0.5 * edges.f_max) edge_voxels.push_back(l);
  ASSERT_GT(edge_voxels.size(), 20u);
  for (int64_t l : edge_voxels) EXPECT_EQ(p[l], 0.0f) << l;
  for (int64_t l = 0; l < p.num_voxels(); l += 7) {  // brute-force distance to the edge voxels
    double best = 1e30;
    for (int64_t e : edge_voxels) best = std::min(best, (grid.to_physical(grid.index(l)) - grid.to_physical(grid.index(e))).norm());
    ASSERT_NEAR(p[l], best, 1e-5 * (1 + best)) << l;
  }
}

TEST(ComputePotential, ReadsOptionsAndNamesBadKeys) {
  const nlohmann::json ok = {{"potential", "distance"}, {"interpolation", "linear"}, {"sigma", 2.0}, {"other", 1}};
  JsonReader r(ok, "f.json", "solver");
  const PotentialOptions o = read_options<PotentialOptions>(r);
  EXPECT_EQ(o.type, PotentialType::kDistance);
  EXPECT_EQ(o.interpolation, PotentialInterpolation::kLinear);
  EXPECT_EQ(o.sigma, 2.0);
  const nlohmann::json empty = nlohmann::json::object();
  JsonReader re(empty, "f.json", "solver");
  const PotentialOptions d = read_options<PotentialOptions>(re);
  EXPECT_EQ(d.type, PotentialType::kIntegrated);
  EXPECT_EQ(d.interpolation, PotentialInterpolation::kCubic);
  EXPECT_EQ(d.sigma, 1.0);
  for (const auto& [key, value] : std::vector<std::pair<std::string, nlohmann::json>>{
           {"potential", "gvf"}, {"interpolation", "quintic"}, {"sigma", -1.0}, {"sigma", "one"}}) {
    const nlohmann::json bad = {{key, value}};
    JsonReader rb(bad, "f.json", "solver");
    try {
      read_options<PotentialOptions>(rb);
      ADD_FAILURE() << key << " accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "solver." + key);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// SmoothPotential

// Keys' cubic convolution kernel (a = -0.5), the Catmull-Rom spline as a kernel.
double keys(double s) {
  s = std::abs(s);
  if (s <= 1) return 1.5 * s * s * s - 2.5 * s * s + 1;
  if (s < 2) return -0.5 * s * s * s + 2.5 * s * s - 4 * s + 2;
  return 0;
}

// Direct evaluation: sum over the 4^D samples around u (voxel index) of the kernel products,
// indices clamped to the grid.
template <int D>
double keys_interpolate(const Grid<D>& grid, const std::vector<double>& v, const Point<D>& x) {
  const Point<D> u = grid.to_continuous_index(x);
  GridIndex<D> base;
  for (int a = 0; a < D; ++a) base[a] = int(std::floor(u[a]));
  double f = 0;
  for (int c = 0; c < (D == 2 ? 16 : 64); ++c) {
    GridIndex<D> idx;
    double w = 1;
    for (int a = 0, rest = c; a < D; ++a, rest /= 4) {
      const int i = base[a] - 1 + rest % 4;
      w *= keys(u[a] - i);
      idx[a] = std::clamp(i, 0, grid.size[a] - 1);
    }
    f += w * v[grid.linear(idx)];
  }
  return f;
}

template <int D>
Point<D> random_point(const Grid<D>& grid, std::mt19937& rng, double lo, double hi_margin) {
  Point<D> u;
  for (int a = 0; a < D; ++a) u[a] = std::uniform_real_distribution<double>(lo, grid.size[a] - 1 - hi_margin)(rng);
  return grid.origin + u.cwiseProduct(grid.spacing);
}

template <int D>
std::vector<double> random_values(const Grid<D>& grid, std::mt19937& rng) {
  std::vector<double> v(grid.num_voxels());
  for (double& x : v) x = std::uniform_real_distribution<double>(0, 1)(rng);
  return v;
}

// A quadratic with integer coefficients in voxel indices: integer values, exact in float.
template <int D>
double quadratic_of_index(const Point<D>& u) {
  double q = u[0] * u[0] + 3 * u[0] * u[1] - 2 * u[1] * u[1] + 4 * u[1] - 7;
  if constexpr (D == 3) q += u[2] * u[2] - u[0] * u[2] + 2 * u[2];
  return q;
}

template <int D>
void expect_cubic_reproduces_quadratic(const Grid<D>& grid) {
  Image<D> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    image[l] = float(quadratic_of_index<D>(grid.index(l).template cast<double>()));
  const SmoothPotential<D> p(image, "cubic");
  std::mt19937 rng(3);
  for (int k = 0; k < 200; ++k) {
    const Point<D> x = random_point(grid, rng, 1.0, 1.0);  // the 4-sample stencil is inside
    const Point<D> u = grid.to_continuous_index(x);
    Point<D> g, gq;
    const double f = p.value_and_gradient(x, g);
    const double q = quadratic_of_index<D>(u);
    EXPECT_NEAR(f, q, 1e-10 * std::max(1.0, std::abs(q)));
    const double h = 1e-5;  // central differences are exact on quadratics
    for (int a = 0; a < D; ++a) {
      Point<D> e = Point<D>::Zero();
      e[a] = h;
      gq[a] = (quadratic_of_index<D>(u + e) - quadratic_of_index<D>(u - e)) / (2 * h) / grid.spacing[a];
    }
    EXPECT_LT((g - gq).norm(), 1e-8 * std::max(1.0, gq.norm()));
  }
}

TEST(SmoothPotential, CubicReproducesQuadratics2dAnd3d) {
  expect_cubic_reproduces_quadratic<2>(make_grid<2>(GridIndex<2>(12, 10), Point<2>(0.7, 1.3), Point<2>(-3, 2)));
  expect_cubic_reproduces_quadratic<3>(make_grid<3>(GridIndex<3>(9, 8, 7), Point<3>(1, 1, 2.5), Point<3>(1, -2, 0.5)));
}

template <int D>
void expect_matches_grid_kernel_and_differences(const Grid<D>& grid, const std::string& interpolation) {
  std::mt19937 rng(11);
  const std::vector<double> v = random_values(grid, rng);
  const SmoothPotential<D> p(grid, v, interpolation);
  for (int64_t l = 0; l < grid.num_voxels(); ++l)  // interpolating: grid values at voxel centres
    ASSERT_NEAR(p.value(grid.to_physical(grid.index(l))), v[l], 1e-12) << l;
  for (int k = 0; k < 300; ++k) {
    // Random points, including a band of 1.5 voxels outside the grid.
    Point<D> x = random_point(grid, rng, -1.5, -1.5);
    if (interpolation == "linear") {  // keep the difference stencil inside one cell
      Point<D> u = grid.to_continuous_index(x);
      for (int a = 0; a < D; ++a) u[a] = std::floor(u[a]) + 0.1 + 0.8 * (u[a] - std::floor(u[a]));
      x = grid.origin + u.cwiseProduct(grid.spacing);
    }
    if (interpolation == "cubic") {
      ASSERT_NEAR(p.value(x), keys_interpolate(grid, v, x), 1e-12);
    }
    Point<D> g;
    p.value_and_gradient(x, g);
    for (int a = 0; a < D; ++a) {
      const double h = 1e-6 * grid.spacing[a];
      Point<D> e = Point<D>::Zero();
      e[a] = h;
      const double fd = (p.value(x + e) - p.value(x - e)) / (2 * h);
      ASSERT_NEAR(g[a], fd, 1e-6 * std::max(1.0, std::abs(g[a]))) << interpolation << " axis " << a;
    }
  }
}

TEST(SmoothPotential, CubicMatchesCatmullRomKernelAndDifferences) {
  expect_matches_grid_kernel_and_differences<2>(make_grid<2>(GridIndex<2>(9, 7), Point<2>(0.7, 1.3), Point<2>(-3, 2)), "cubic");
  expect_matches_grid_kernel_and_differences<3>(make_grid<3>(GridIndex<3>(6, 7, 5), Point<3>(1, 1, 2.5), Point<3>(1, -2, 0.5)), "cubic");
}

TEST(SmoothPotential, LinearMatchesDifferences) {
  expect_matches_grid_kernel_and_differences<2>(make_grid<2>(GridIndex<2>(9, 7), Point<2>(0.7, 1.3), Point<2>(-3, 2)), "linear");
  expect_matches_grid_kernel_and_differences<3>(make_grid<3>(GridIndex<3>(6, 7, 5), Point<3>(1, 1, 2.5), Point<3>(1, -2, 0.5)), "linear");
}

template <int D>
void expect_linear_exact_on_linear(const Grid<D>& grid) {
  Point<D> slope;
  for (int a = 0; a < D; ++a) slope[a] = 0.5 - 0.7 * a;
  auto lin = [&](const Point<D>& x) { return 2.0 + slope.dot(x); };
  std::vector<double> v(grid.num_voxels());
  for (int64_t l = 0; l < grid.num_voxels(); ++l) v[l] = lin(grid.to_physical(grid.index(l)));
  const SmoothPotential<D> p(grid, v, "linear");
  std::mt19937 rng(5);
  for (int k = 0; k < 100; ++k) {
    const Point<D> x = random_point(grid, rng, 0.0, 0.0);
    Point<D> g;
    EXPECT_NEAR(p.value_and_gradient(x, g), lin(x), 1e-12);
    EXPECT_LT((g - slope).norm(), 1e-12);
  }
  // Outside along axis 0: the value at the nearest box point, no slope along that axis.
  Point<D> inner = random_point(grid, rng, 0.0, 0.0), outer = inner;
  inner[0] = grid.origin[0];
  outer[0] = grid.origin[0] - 3.0;
  Point<D> g;
  EXPECT_NEAR(p.value_and_gradient(outer, g), lin(inner), 1e-12);
  EXPECT_EQ(g[0], 0.0);
  EXPECT_NEAR(g[1], slope[1], 1e-12);
}

TEST(SmoothPotential, LinearIsExactOnLinearFunctions) {
  expect_linear_exact_on_linear<2>(make_grid<2>(GridIndex<2>(9, 7), Point<2>(0.7, 1.3), Point<2>(-3, 2)));
  expect_linear_exact_on_linear<3>(make_grid<3>(GridIndex<3>(6, 7, 5), Point<3>(1, 1, 2.5), Point<3>(1, -2, 0.5)));
}

TEST(SmoothPotential, CubicIsConstantFarOutside) {
  const Grid<3> grid = make_grid<3>(GridIndex<3>(6, 7, 5), Point<3>(1, 1, 2.5), Point<3>(0, 0, 0));
  std::mt19937 rng(2);
  const std::vector<double> v = random_values(grid, rng);
  const SmoothPotential<3> p(grid, v, "cubic");
  Point<3> g;
  // Beyond one voxel past the last centre along every axis: the corner voxel's value.
  EXPECT_NEAR(p.value_and_gradient(Point<3>(8.5, 1e9, 30), g), v[grid.linear(GridIndex<3>(5, 6, 4))], 1e-15);
  EXPECT_EQ(g.norm(), 0.0);
  EXPECT_NEAR(p.value_and_gradient(Point<3>(-2.5, -40, -1e300), g), v[0], 1e-15);
  EXPECT_EQ(g.norm(), 0.0);
  EXPECT_TRUE(std::isnan(p.value(Point<3>(std::nan(""), 0, 0))));
}

TEST(SmoothPotential, ParallelEvaluationMatchesSerial) {
  // The global solve evaluates one shared potential from several threads.
  const Grid<2> grid = make_grid<2>(GridIndex<2>(30, 20), Point<2>(1, 1.5), Point<2>(0, 0));
  std::mt19937 rng(9);
  const SmoothPotential<2> p(grid, random_values(grid, rng), "cubic");
  std::vector<Point<2>> points(2000);
  for (Point<2>& x : points) x = random_point(grid, rng, -1.0, -1.0);
  std::vector<double> serial(points.size()), parallel(points.size());
  for (size_t i = 0; i < points.size(); ++i) serial[i] = p.value(points[i]);
#pragma omp parallel for num_threads(2) schedule(dynamic, 7)
  for (int64_t i = 0; i < int64_t(points.size()); ++i) parallel[i] = p.value(points[i]);
  EXPECT_TRUE(serial == parallel);
}

// P(x) as a one-residual cost function, for Ceres' GradientChecker.
template <int D>
class PotentialCost final : public ceres::CostFunction {
 public:
  explicit PotentialCost(const SmoothPotential<D>& p) : p_(p) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(D);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Point<D> x = Eigen::Map<const Point<D>>(parameters[0]);
    Point<D> g;
    residuals[0] = p_.value_and_gradient(x, g);
    if (jacobians && jacobians[0])
      for (int a = 0; a < D; ++a) jacobians[0][a] = g[a];
    return true;
  }

 private:
  SmoothPotential<D> p_;
};

template <int D>
void expect_gradient_checker_passes(const Grid<D>& grid) {
  std::mt19937 rng(17);
  const SmoothPotential<D> p(grid, random_values(grid, rng), "cubic");
  const PotentialCost<D> cost(p);
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-5;  // see CubicPassesCeresGradientChecker
  const std::vector<const ceres::Manifold*>* euclidean = nullptr;
  const ceres::GradientChecker checker(&cost, euclidean, numeric);
  for (int k = 0; k < 50; ++k) {
    Point<D> x = random_point(grid, rng, -0.5, -0.5);
    const double* params[] = {x.data()};
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(params, 1e-7, &results)) << results.error_log;
  }
}

TEST(SmoothPotential, CubicPassesCeresGradientChecker) {
  expect_gradient_checker_passes<2>(make_grid<2>(GridIndex<2>(9, 7), Point<2>(0.7, 1.3), Point<2>(-3, 2)));
  expect_gradient_checker_passes<3>(make_grid<3>(GridIndex<3>(6, 7, 5), Point<3>(1, 1, 2.5), Point<3>(1, -2, 0.5)));
}

}  // namespace
}  // namespace dsnake
