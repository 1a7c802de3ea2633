// The profile force (energies/profile.h) on images with edges at known places: a blurred disk and
// ball reached from 3 mm off, two concentric edges of opposite polarity picked by the polarity,
// the polarity learned from the start, a reference image's profiles carried to a shifted target
// of another intensity scale, bad keys, and the same bits for 1 and 2 threads.
#include "energies/profile.h"

#include "framework/core/errors.h"
#include "tests/energies/edge_images.h"
#include "tests/energy_fixtures.h"

#include <gtest/gtest.h>
#include <omp.h>

namespace dsnake {
namespace {

using namespace test_support;

ProfileOptions with_polarity(EdgePolarity p) {
  ProfileOptions o;
  o.polarity = p;
  return o;
}

// A disk of radius 10 mm blurred by 1.5 mm (and by the energy's sigma 1 mm); contours started
// 3 mm outside and 3 mm inside end on its edge, where the blurred gradient peaks, 0.16 mm inside
// r = 10 (blurred_edge_radius): mean radial error to it < 0.06 mm, largest < 0.12 mm (1 mm grid).
TEST(ProfileEnergy, Disk2DFromThreeMmOffEndsOnTheEdge) {
  const Image<2> image = radial_image<2>(64, 1.0, bright_disk(10.0), 1.5);
  for (double start : {13.0, 7.0}) {
    SCOPED_TRACE(start);
    const Template<2> t = round_template<2>(start);
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    ProfileEnergy<2> energy(with_polarity(EdgePolarity::kBrightInside));
    iterate_alone<2>(energy, EnergyContext<2>{&t, &image}, snake, 40);
    const double edge = blurred_edge_radius(2, 10.0, std::hypot(1.5, 1.0));
    const auto [mean, worst] = radial_error(snake, edge);
    std::printf("profile 2D from r = %.0f: edge at %.3f, mean error %.3f, largest %.3f\n", start, edge, mean, worst);
    EXPECT_LT(mean, 0.06);
    EXPECT_LT(worst, 0.12);
  }
}

// A ball of radius 8 mm on a 0.8 mm grid, blurred by 1.2 mm (and 1 mm); an icosphere started at
// 11 mm ends on its edge (0.31 mm inside r = 8, blurred_edge_radius) within 0.06 mm mean, 0.12 mm
// largest; "auto" learns bright_inside.
TEST(ProfileEnergy, Ball3DFromThreeMmOffEndsOnTheEdge) {
  const Image<3> image = radial_image<3>(36, 0.8, bright_disk(8.0), 1.2);
  const Template<3> t = round_template<3>(11.0);
  Snake<3> snake = Snake<3>::from_template(t, t.positions);
  ProfileEnergy<3> energy(with_polarity(EdgePolarity::kAuto));
  iterate_alone<3>(energy, EnergyContext<3>{&t, &image}, snake, 40);
  EXPECT_EQ(energy.polarity(), EdgePolarity::kBrightInside);
  const double edge = blurred_edge_radius(3, 8.0, std::hypot(1.2, 1.0));
  const auto [mean, worst] = radial_error(snake, edge);
  std::printf("profile 3D from r = 11: edge at %.3f, mean error %.3f, largest %.3f\n", edge, mean, worst);
  EXPECT_LT(mean, 0.06);
  EXPECT_LT(worst, 0.12);
}

// max_travel: the same disk's edge lies 3 mm inside a contour started at r = 13; with max_travel
// 1 mm every vertex stops on the ball of 1 mm about its start (r = 12, to 1e-9: the point where
// the normal leaves the ball is a candidate of its own and matches best), with 2.5 mm at r = 10.5,
// and 4 mm (beyond the edge) lets it reach the edge as without a bound.
TEST(ProfileEnergy, MaxTravelKeepsEveryVertexNearItsStart) {
  const Image<2> image = radial_image<2>(64, 1.0, bright_disk(10.0), 1.5);
  const Template<2> t = round_template<2>(13.0);
  const double edge = blurred_edge_radius(2, 10.0, std::hypot(1.5, 1.0));
  for (auto [travel, radius, tolerance] : {std::tuple{1.0, 12.0, 1e-9}, std::tuple{2.5, 10.5, 1e-9},
                                           std::tuple{4.0, edge, 0.12}}) {
    SCOPED_TRACE(travel);
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    ProfileOptions o = with_polarity(EdgePolarity::kBrightInside);
    o.max_travel = travel;
    ProfileEnergy<2> energy(o);
    iterate_alone<2>(energy, EnergyContext<2>{&t, &image}, snake, 40);
    const auto [mean, worst] = radial_error(snake, radius);
    EXPECT_LT(worst, tolerance);
    for (int v = 0; v < snake.num_vertices(); ++v)
      EXPECT_LE((snake.positions()[v] - t.positions[v]).norm(), travel + 1e-9);
  }
}

// Bright inside r = 8, dark ring, bright beyond r = 14; started half-way (r = 11, 3 mm from
// both): bright_inside goes to 8, dark_inside to 14.
TEST(ProfileEnergy, ConcentricEdgesArePickedByThePolarity) {
  const Image<2> image = radial_image<2>(64, 1.0, dark_ring(8.0, 14.0), 1.0);
  const Template<2> t = round_template<2>(11.0);
  for (auto [polarity, radius] : {std::pair{EdgePolarity::kBrightInside, 8.0}, std::pair{EdgePolarity::kDarkInside, 14.0}}) {
    SCOPED_TRACE(enum_name(polarity));
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    ProfileEnergy<2> energy(with_polarity(polarity));
    iterate_alone<2>(energy, EnergyContext<2>{&t, &image}, snake, 40);
    EXPECT_LT(radial_error(snake, radius).second, 0.2);
  }
}

// "auto": a bright disk gives bright_inside, its negative dark_inside, from inside or outside.
TEST(ProfileEnergy, AutoLearnsThePolarityFromTheStart) {
  const Image<2> bright = radial_image<2>(64, 1.0, bright_disk(10.0), 1.5);
  const Image<2> dark = radial_image<2>(64, 1.0, [](double r) { return r < 10.0 ? 20.0 : 180.0; }, 1.5);
  for (double start : {12.0, 8.5}) {
    const Template<2> t = round_template<2>(start);
    const Snake<2> snake = Snake<2>::from_template(t, t.positions);
    ProfileEnergy<2> a, b;
    a.bind(EnergyContext<2>{&t, &bright}, snake);
    b.bind(EnergyContext<2>{&t, &dark}, snake);
    EXPECT_EQ(a.polarity(), EdgePolarity::kBrightInside) << start;
    EXPECT_EQ(b.polarity(), EdgePolarity::kDarkInside) << start;
  }
}

// The template sits on the outer edge (r = 14) of the ring image, the reference; the target is
// that image moved by (2, -2) mm with intensities 0.4 I + 50. Both expected-profile modes bring
// the contour onto the moved edge (largest error < 0.25 mm); the generic step edge of the wrong
// polarity (bright_inside) does not (it finds the inner edge).
TEST(ProfileEnergy, ReferenceImageProfilesRegisterAShiftedRescaledTarget) {
  const Image<2> reference = radial_image<2>(72, 1.0, dark_ring(8.0, 14.0), 1.0);
  const Point<2> shift(2.0, -2.0);
  const Image<2> target = radial_image<2>(72, 1.0, [](double r) { return 0.4 * (r < 8 ? 200 : r < 14 ? 50 : 200) + 50; }, 1.0, shift);
  const Template<2> t = round_template<2>(14.0);
  EnergyContext<2> context{&t, &target};
  context.reference_image = &reference;
  for (auto mode : {ReferenceProfile::kPerVertex, ReferenceProfile::kMean}) {
    SCOPED_TRACE(enum_name(mode));
    ProfileOptions o;
    o.reference_profile = mode;
    o.polarity = EdgePolarity::kBrightInside;  // ignored: the reference decides
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    ProfileEnergy<2> energy(o);
    iterate_alone<2>(energy, context, snake, 40);
    EXPECT_LT(radial_error(snake, 14.0, shift).second, 0.25);
  }
  Snake<2> snake = Snake<2>::from_template(t, t.positions);
  ProfileEnergy<2> step(with_polarity(EdgePolarity::kBrightInside));
  iterate_alone<2>(step, EnergyContext<2>{&t, &target}, snake, 40);
  EXPECT_GT(radial_error(snake, 14.0, shift).first, 2.0);
}

// Bad keys are refused with the JSON path of the key.
TEST(ProfileEnergy, BadKeysNameTheirPath) {
  test_support::expect_refused_at<2>({{R"({"type": "profile", "step": 0})", "energies[0].step"},
                             {R"({"type": "profile", "step": 1.5})", "energies[0].step"},
                             {R"({"type": "profile", "search": -1})", "energies[0].search"},
                             {R"({"type": "profile", "length": 0})", "energies[0].length"},
                             {R"({"type": "profile", "sigma": -1})", "energies[0].sigma"},
                             {R"({"type": "profile", "polarity": "any"})", "energies[0].polarity"},
                             {R"({"type": "profile", "reference_profile": "median"})", "energies[0].reference_profile"},
                             {R"({"type": "profile", "min_improvement": 1})", "energies[0].min_improvement"},
                             {R"({"type": "profile", "min_improvement": -0.1})", "energies[0].min_improvement"},
                             {R"({"type": "profile", "local_polarity": "yes"})", "energies[0].local_polarity"},
                             {R"({"type": "profile", "max_travel": -1})", "energies[0].max_travel"}});
}

// One and two threads give the same proposals, bit for bit (a 642-vertex sphere, 3D).
TEST(ProfileEnergy, SameBitsForOneAndTwoThreads) {
  const Image<3> image = radial_image<3>(32, 1.0, bright_disk(8.0), 1.0);
  const Template<3> t = round_template<3>(9.5);
  const Snake<3> snake = Snake<3>::from_template(t, perturbed<3>(t.positions, 0.7, 3));
  test_support::expect_same_proposals_at_one_and_two_threads<3>([] { return ProfileEnergy<3>(); }, EnergyContext<3>{&t, &image}, snake);
}

}  // namespace
}  // namespace dsnake
