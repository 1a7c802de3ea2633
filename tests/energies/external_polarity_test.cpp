// The external energy's polarity rule (energies/external.h) on images with edges at known places:
// on an edge of the right polarity nothing changes (same bits as "any"); between two concentric
// edges of opposite polarity the rule picks the edge of its polarity whichever is nearer; "auto"
// learns the sign from the start; bad keys name their path; one and two threads give the same bits.
#include "energies/external.h"
#include "energies/polarity.h"

#include "fields/gvf.h"
#include "framework/core/errors.h"
#include "framework/core/image_filters.h"
#include "tests/energies/edge_images.h"
#include "tests/energy_fixtures.h"

#include <gtest/gtest.h>
#include <omp.h>
#include <cmath>
#include <algorithm>
#include <random>

namespace dsnake {
namespace {

using namespace test_support;

ExternalOptions rule(PolarityRule polarity) {
  ExternalOptions o;
  o.tau = 0.5;
  o.normalize = ForceNormalization::kMax;
  o.polarity = polarity;
  return o;
}

// A bright disk (r = 10): for contours at r = 7 ... 13 the bright_inside rule proposes exactly
// what "any" does (every force there pulls onto the one edge, whose polarity is right).
TEST(ExternalPolarity, RightPolarityChangesNothing) {
  const Image<2> image = radial_image<2>(64, 1.0, bright_disk(10.0), 1.5);
  GvfField<2> field;
  field.compute(image);
  for (double r = 7.0; r <= 13.0; r += 0.5) {
    const Template<2> t = round_template<2>(r);
    const Snake<2> snake = Snake<2>::from_template(t, t.positions);
    ExternalEnergy<2> any(rule(PolarityRule::kAny)), bright(rule(PolarityRule::kBrightInside));
    any.bind(EnergyContext<2>{&t, &image, &field}, snake);
    bright.bind(EnergyContext<2>{&t, &image, &field}, snake);
    PointList<2> a(snake.num_vertices()), b(snake.num_vertices());
    any.propose(snake, a);
    bright.propose(snake, b);
    for (int v = 0; v < snake.num_vertices(); ++v) ASSERT_EQ(a[v], b[v]) << "r " << r << " vertex " << v;
  }
}

// Bright inside r = 8, dark ring, bright beyond r = 14, GVF field; a contour started at r = 10,
// nearer the inner edge: "any" and bright_inside end on the inner edge (so does bright_inside
// from r = 13, nearer the outer one), dark_inside on the outer
// one: where "any" ends when started at r = 13, next to it (within 0.2 mm, two steps tau; both within 0.3 mm of
// the blurred edges' radii, GVF's own equilibrium being a little inside the outer edge's).
// normalize unit, tau 0.1 mm, 300 iterations: the GVF between the two edges is too weak for a
// step proportional to it to cross in time.
TEST(ExternalPolarity, ConcentricEdgesArePickedByThePolarity) {
  const Image<2> image = radial_image<2>(72, 1.0, dark_ring(8.0, 14.0), 1.0);
  GvfField<2> field;
  field.compute(image);
  const double inner = blurred_edge_radius(2, 8.0, std::hypot(1.0, 1.0));
  const double outer = blurred_edge_radius(2, 14.0, std::hypot(1.0, 1.0));
  // the snake after 300 iterations from a circle of radius `start`, and its radii's mean and spread
  auto run = [&](PolarityRule polarity, double start) {
    const Template<2> t = round_template<2>(start);
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    ExternalOptions o = rule(polarity);
    o.normalize = ForceNormalization::kUnit;
    o.tau = 0.1;
    ExternalEnergy<2> energy(o);
    iterate_alone<2>(energy, EnergyContext<2>{&t, &image, &field}, snake, 300);
    const double mean = mean_radial_offset(snake, 0.0);
    std::printf("polarity %s from r = %.0f: mean radius %.3f, largest deviation %.3f\n", enum_name(polarity), start,
                mean, radial_error(snake, mean).second);
    return snake;
  };
  const Snake<2> any_inner = run(PolarityRule::kAny, 10.0), any_outer = run(PolarityRule::kAny, 13.0);
  const double r_inner = mean_radial_offset(any_inner, 0.0), r_outer = mean_radial_offset(any_outer, 0.0);
  EXPECT_LT(std::abs(r_inner - inner), 0.3);
  EXPECT_LT(std::abs(r_outer - outer), 0.3);
  EXPECT_LT(radial_error(run(PolarityRule::kBrightInside, 10.0), r_inner).second, 0.2);
  EXPECT_LT(radial_error(run(PolarityRule::kDarkInside, 10.0), r_outer).second, 0.2);
  EXPECT_LT(radial_error(run(PolarityRule::kBrightInside, 13.0), r_inner).second, 0.2);
}

// "auto": bright_inside for a bright disk, dark_inside for its negative.
TEST(ExternalPolarity, AutoLearnsThePolarityFromTheStart) {
  const Image<2> bright = radial_image<2>(64, 1.0, bright_disk(10.0), 1.5);
  const Image<2> dark = radial_image<2>(64, 1.0, [](double r) { return r < 10.0 ? 20.0 : 180.0; }, 1.5);
  GvfField<2> field;
  field.compute(bright);
  const Template<2> t = round_template<2>(12.0);
  const Snake<2> snake = Snake<2>::from_template(t, t.positions);
  ExternalEnergy<2> a(rule(PolarityRule::kAuto)), b(rule(PolarityRule::kAuto));
  a.bind(EnergyContext<2>{&t, &bright, &field}, snake);
  b.bind(EnergyContext<2>{&t, &dark, &field}, snake);
  EXPECT_EQ(a.polarity(), EdgePolarity::kBrightInside);
  EXPECT_EQ(b.polarity(), EdgePolarity::kDarkInside);
}

TEST(ExternalPolarity, BadKeysNameTheirPath) {
  test_support::expect_refused_at<2>({{R"({"type": "external", "polarity": "inside"})", "energies[0].polarity"},
                             {R"({"type": "external", "polarity_range": 0})", "energies[0].polarity_range"},
                             {R"({"type": "external", "polarity_sigma": -1})", "energies[0].polarity_sigma"},
                             {R"({"type": "external", "polarity_floor": -0.5})", "energies[0].polarity_floor"}});
}

// One and two threads give the same proposals, bit for bit (a 642-vertex sphere on a ball, 3D).
TEST(ExternalPolarity, SameBitsForOneAndTwoThreads) {
  const Image<3> image = radial_image<3>(32, 1.0, dark_ring(6.0, 11.0), 1.0);
  GvfField<3> field;
  field.compute(image);
  Template<3> t = make_icosphere(3);
  for (auto& p : t.positions) p *= 8.0;
  const Snake<3> snake = Snake<3>::from_template(t, perturbed<3>(t.positions, 0.7, 3));
  test_support::expect_same_proposals_at_one_and_two_threads<3>([&] { return ExternalEnergy<3>(rule(PolarityRule::kDarkInside)); }, EnergyContext<3>{&t, &image, &field}, snake);
}

// The polarity rule's noise level is the median of the voxels' gradient magnitudes (or 1% of the
// largest): the radix selection gives the value an nth_element over all voxels gives, at 1 and 2
// threads, on a noisy volume, on one with many equal magnitudes and on a constant one, whether
// it gathers after the first pass (the default bound) or refines 16 bits at a time: down to a
// few values, or to all 64 bits without gathering (bound 0; the constant and the stepped volume
// then take four passes, as a large phantom does).
TEST(GradientNoiseLevel, EqualsTheMedianOfAllMagnitudes) {
  Grid<3> g;
  g.size = {67, 41, 30};  // > 65536 voxels: the parallel passes
  g.spacing = {0.8, 1.1, 2.0};
  auto reference = [&](const Image<3>& img) {
    const std::vector<double> u(img.data().begin(), img.data().end());
    std::vector<double> m;
    for (int64_t l = 0; l < int64_t(u.size()); ++l) {
      double s = 0;
      for (int a = 0; a < 3; ++a) s += std::pow(partial_derivative(g, u, l, a), 2);
      if (s == 0 && u[l] == 0) continue;  // padding
      m.push_back(std::sqrt(s));
    }
    if (m.empty()) return 0.0;
    const double largest = *std::max_element(m.begin(), m.end());
    std::nth_element(m.begin(), m.begin() + m.size() / 2, m.end());
    return std::max(m[m.size() / 2], 0.01 * largest);
  };
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.0f, 5.0f);
  Image<3> noisy(g), steps(g), ramp(g), flat(g, 7.0f), padded(g), zero(g, 0.0f);
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    noisy[l] = 100.0f * (l % 67 > 30) + noise(rng);
    steps[l] = float((l / 67) % 41 > 20 ? 10 : 0);  // most magnitudes 0, a few equal ones
    ramp[l] = 0.25f * float(l % 67);                  // the same non-zero magnitude everywhere
    padded[l] = (l % 67) < 20 ? 50.0f + noise(rng) : 0.0f;  // noisy tissue in 20 of 67 columns, padding
  }
  for (const Image<3>* img : {&noisy, &steps, &ramp, &flat, &padded, &zero}) {
    const double expected = reference(*img);
    for (const int threads : {1, 2}) {
      omp_set_num_threads(threads);
      EXPECT_EQ(gradient_noise_level(*img), expected) << threads;
      for (const int64_t gather_max : {int64_t(0), int64_t(1), int64_t(50), int64_t(5000)})
        EXPECT_EQ(detail::gradient_noise_level(*img, gather_max), expected) << threads << " " << gather_max;
    }
  }
  EXPECT_GT(reference(noisy), 0.0);
  EXPECT_GT(reference(ramp), 0.0);
  EXPECT_EQ(gradient_noise_level(zero), 0.0);
}

// A skull-stripped scan: noisy tissue in an eighth of the volume, exact zeros around it. The
// noise level is the tissue's (the median of |grad I| over its voxels: noise of 4 per voxel
// gives central differences of 4 / sqrt(2) per axis, a magnitude whose median is about 4.4, a
// little more with the tissue's border), not the 1% floor (0.4 here) that the median over all
// voxels, most of them padding with gradient 0, falls to.
TEST(GradientNoiseLevel, PaddingAroundASkullStrippedScanIsNotNoise) {
  Grid<3> g;
  g.size = {80, 80, 80};
  g.spacing = {1.0, 1.0, 1.0};
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 4.0f);
  Image<3> stripped(g);
  for (int64_t l = 0; l < g.num_voxels(); ++l) {
    const int x = int(l % 80), y = int(l / 80 % 80), z = int(l / 6400);
    const bool inside = x >= 20 && x < 60 && y >= 20 && y < 60 && z >= 20 && z < 60;
    stripped[l] = inside ? 80.0f + noise(rng) : 0.0f;
  }
  const double level = gradient_noise_level(stripped);
  EXPECT_GT(level, 4.0);
  EXPECT_LT(level, 5.5);
}

}  // namespace
}  // namespace dsnake
