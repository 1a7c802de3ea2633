// The patch force (energies/patch.h) on objects whose boundary changes polarity: darker than
// their surroundings on one side and brighter on the other (the paper's Fig. 3 problem, where one
// expected edge cannot fit the whole boundary). The atlas image holds the object where the
// template lies; the scan holds it moved, or with another contrast. Known answers: the expected
// patches are the atlas's samples at the rest positions (exactly, at template and at inserted
// vertices), the object's moved boundary is reached, the atlas's own object is a fixed point,
// a linear change of contrast changes nothing (an inverted one either: its sign is found), no
// atlas is refused, and 1 and 2 threads give the same bits. Without an atlas, the profile force's local polarity on the same object.
#include "energies/patch.h"

#include "energies/profile.h"
#include "energies/rest_positions.h"
#include "framework/core/errors.h"
#include "tests/energies/edge_images.h"
#include "tests/energy_fixtures.h"

#include <Eigen/Dense>

#include <gtest/gtest.h>
#include <random>
#include <omp.h>

namespace dsnake {
namespace {

using namespace test_support;

// A disk (ball) of radius 10 mm at `centre`, intensity 100, in surroundings of 200 where x < 0
// (the object darker) and of 20 where x >= 0 (the object brighter); a 1 mm grid. Each edge is a
// step blurred by a Gaussian of 1.2 mm, evaluated at the voxel centres (no rasterised step, so a
// moved object is exactly the moved image). The intensity scale a and offset b give a linear
// change of contrast a I + b.
template <int D>
Image<D> mixed_polarity(const Point<D>& centre, double a = 1.0, double b = 0.0) {
  Grid<D> g;
  g.size = GridIndex<D>::Constant(D == 2 ? 48 : 36);
  g.spacing = Point<D>::Constant(1.0);
  g.origin = Point<D>::Constant(-0.5 * (g.size[0] - 1));
  Image<D> image(g);
  auto step = [](double d) { return 0.5 * std::erfc(d / (1.2 * std::sqrt(2.0))); };  // 1 inside (d < 0)
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const Point<D> x = g.to_physical(g.index(l));
    const double outside = 200.0 * step(x[0] - centre[0]) + 20.0 * (1.0 - step(x[0] - centre[0]));
    const double inside = step((x - centre).norm() - 10.0);
    image[l] = static_cast<float>(a * (100.0 * inside + outside * (1.0 - inside)) + b);
  }
  return image;
}

// Iterates the patch force alone (the snake moves to its proposal) with the atlas as reference.
template <int D>
void iterate_patch(PatchEnergy<D>& energy, const Template<D>& t, const Image<D>& scan, const Image<D>& atlas,
                   Snake<D>& snake, int iterations) {
  EnergyContext<D> context{&t, &scan};
  context.reference_image = &atlas;
  iterate_alone<D>(energy, context, snake, iterations);
}

template <int D>
Template<D> disk_template() {
  return round_template<D>(10.0, Point<D>::Zero(), 64);
}

// The scan's object moved by `shift`: every vertex ends within 0.08 mm of the moved circle
// (mean within 0.03 mm), from a start up to 1.8 mm off.
template <int D>
void reaches_moved_object(const Point<D>& shift, double a, double b, PatchContrast contrast = PatchContrast::kAuto,
                          PatchGradient gradient = PatchGradient::kScan) {
  const Image<D> atlas = mixed_polarity<D>(Point<D>::Zero());
  const Image<D> scan = mixed_polarity<D>(shift, a, b);
  const Template<D> t = disk_template<D>();
  Snake<D> snake = Snake<D>::from_template(t, t.positions);
  PatchOptions options;
  options.contrast = contrast;
  options.gradient = gradient;
  PatchEnergy<D> energy(options);
  iterate_patch<D>(energy, t, scan, atlas, snake, 60);
  EXPECT_EQ(energy.contrast_sign(), a > 0 ? 1 : -1);
  const auto [mean, worst] = radial_error(snake, 10.0, shift);
  const auto [mean0, worst0] = radial_error(Snake<D>::from_template(t, t.positions), 10.0, shift);
  std::printf("patch %dD: distance to the moved boundary %.3f mean, %.3f largest (start %.3f, %.3f)\n", D, mean,
              worst, mean0, worst0);
  EXPECT_GT(worst0, 1.5);
  EXPECT_LT(mean, 0.03);
  EXPECT_LT(worst, 0.08);
}

TEST(PatchEnergy, MixedPolarityDiskReachesItsMovedBoundary2D) {
  reaches_moved_object<2>(Point<2>(1.5, -1.0), 1.0, 0.0);
}
TEST(PatchEnergy, MixedPolarityBallReachesItsMovedBoundary3D) {
  reaches_moved_object<3>(Point<3>(1.2, -0.8, 0.6), 1.0, 0.0);
}
// A linear change of contrast (a = 0.4, b = 37) between atlas and scan changes nothing.
TEST(PatchEnergy, LinearChangeOfContrastIsIgnored) {
  reaches_moved_object<2>(Point<2>(1.5, -1.0), 0.4, 37.0);
}
// The Gauss-Newton step with the atlas patch's gradients (inverse compositional) or the mean of
// both (efficient second-order minimisation) reaches the same boundary, also under a change of
// contrast.
TEST(PatchEnergy, EveryGradientChoiceReachesTheMovedBoundary) {
  reaches_moved_object<2>(Point<2>(1.5, -1.0), 0.4, 37.0, PatchContrast::kAuto, PatchGradient::kAtlas);
  reaches_moved_object<2>(Point<2>(1.5, -1.0), -0.7, 250.0, PatchContrast::kAuto, PatchGradient::kBoth);
  reaches_moved_object<3>(Point<3>(1.2, -0.8, 0.6), 1.0, 0.0, PatchContrast::kAuto, PatchGradient::kBoth);
}
// With noise in the scan only (the atlas an average, the scan one acquisition), the step with the
// atlas patch's gradients takes its contrast from the scan regressed on the atlas patch, which
// the scan's noise does not bias: averaged over noise draws, the first step's component along the
// vertex normals is the same share of the true move as without noise. Noise of sigma 40 on edges
// of 80 to 100, fine patches (sigma 0.5 mm, +-2 mm): the patches correlate ~0.83, and the fit of
// the atlas patch on the scan's would shorten the step to ~0.6 of its noiseless length.
TEST(PatchEnergy, AtlasGradientStepIsNotShortenedByScanNoise) {
  const Point<2> shift(0.6, 0.0);
  const Image<2> atlas = mixed_polarity<2>(Point<2>::Zero());
  const Template<2> t = disk_template<2>();
  double mean_ncc = 0.0;
  auto normal_share = [&](PatchGradient gradient, double noise_sigma, int seed) {
    Image<2> scan = mixed_polarity<2>(shift);
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, 1.0);
    for (int64_t l = 0; l < scan.num_voxels(); ++l) scan[l] += static_cast<float>(noise_sigma * n(rng));
    PatchOptions options;
    options.gradient = gradient;
    options.sigma = 0.5;
    options.radius = 2.0;
    options.spacing = 0.5;
    options.min_correlation = -1.0;  // every vertex steps, however noisy its patch
    options.max_step = 10.0;
    PatchEnergy<2> energy(options);
    EnergyContext<2> context{&t, &scan};
    context.reference_image = &atlas;
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    energy.bind(context, snake);
    PointList<2> out(snake.num_vertices());
    energy.propose(snake, out);
    double moved = 0.0, truth = 0.0;
    mean_ncc = 0.0;
    for (int v = 0; v < snake.num_vertices(); ++v) {
      const Point<2> normal = t.positions[v].normalized();
      moved += normal.dot(out[v] - t.positions[v]) * normal.dot(shift);
      truth += normal.dot(shift) * normal.dot(shift);
      mean_ncc += energy.correlations()[v] / snake.num_vertices();
    }
    return moved / truth;
  };
  constexpr int kDraws = 20;
  const double clean = normal_share(PatchGradient::kAtlas, 0.0, 1);
  double noisy = 0.0, ncc = 0.0;
  for (int seed = 1; seed <= kDraws; ++seed) {
    noisy += normal_share(PatchGradient::kAtlas, 40.0, seed) / kDraws;
    ncc += mean_ncc / kDraws;
  }
  std::printf("atlas gradients: share of the true normal move %.3f without noise, %.3f with (mean NCC %.2f)\n", clean,
              noisy, ncc);
  EXPECT_NEAR(clean, 1.0, 0.1);
  EXPECT_LT(ncc, 0.9);
  EXPECT_NEAR(noisy / clean, 1.0, 0.1);
}

// An inverted contrast (a = -0.7, b = 250: the atlas's dark side bright in the scan, as fluid is
// between T1 and T2) is a linear change too: contrast auto finds its sign from the start's
// correlations, and negative says it; both reach the moved boundary as above.
TEST(PatchEnergy, InvertedContrastIsFoundAndFollowed2D) {
  reaches_moved_object<2>(Point<2>(1.5, -1.0), -0.7, 250.0);
  reaches_moved_object<2>(Point<2>(1.5, -1.0), -0.7, 250.0, PatchContrast::kNegative);
}
TEST(PatchEnergy, InvertedContrastIsFoundAndFollowed3D) {
  reaches_moved_object<3>(Point<3>(1.2, -0.8, 0.6), -0.7, 250.0);
}
// Told the wrong sign, no vertex has evidence (every NCC is below min_correlation) and all hold:
// positive on an inverted scan, negative on the atlas's own contrast.
TEST(PatchEnergy, TheWrongContrastSignHoldsEveryVertex) {
  const Image<2> atlas = mixed_polarity<2>(Point<2>::Zero());
  const Template<2> t = disk_template<2>();
  for (const auto& [a, contrast] : {std::pair{-0.7, PatchContrast::kPositive}, std::pair{1.0, PatchContrast::kNegative}}) {
    const Image<2> scan = mixed_polarity<2>(Point<2>(1.5, -1.0), a, a > 0 ? 0.0 : 250.0);
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    PatchOptions options;
    options.contrast = contrast;
    PatchEnergy<2> energy(options);
    iterate_patch<2>(energy, t, scan, atlas, snake, 10);
    for (int v = 0; v < snake.num_vertices(); ++v) EXPECT_EQ(snake.positions()[v], t.positions[v]);
    for (double c : energy.correlations()) EXPECT_LT(c, 0.5);
  }
}

// Started on the atlas's own object, nothing moves (the NCC is 1 and its gradient 0 there).
template <int D>
void holds_fixed_point() {
  const Image<D> atlas = mixed_polarity<D>(Point<D>::Zero());
  const Image<D> scan = mixed_polarity<D>(Point<D>::Zero(), 2.0, -15.0);
  const Template<D> t = disk_template<D>();
  Snake<D> snake = Snake<D>::from_template(t, t.positions);
  PatchEnergy<D> energy;
  iterate_patch<D>(energy, t, scan, atlas, snake, 30);
  double worst = 0.0;
  for (int v = 0; v < snake.num_vertices(); ++v) worst = std::max(worst, (snake.positions()[v] - t.positions[v]).norm());
  EXPECT_LT(worst, 1e-3);
  for (double c : energy.correlations()) EXPECT_GT(c, 0.999);
}
TEST(PatchEnergy, AtlasObjectIsAFixedPoint2D) { holds_fixed_point<2>(); }
TEST(PatchEnergy, AtlasObjectIsAFixedPoint3D) { holds_fixed_point<3>(); }

// The expected patches are the atlas's samples at p + L_v^{-1} h k, mean removed, unit norm: at a
// template vertex p is its template position; at a vertex inserted at the midpoint of an edge of a
// snake that is a rotated, scaled, moved copy of the template, p is its rest position (on the
// circle beside the template edge's midpoint, rest_positions.h); L_v and the placement's L are
// the copy's linear part.
TEST(PatchEnergy, ExpectedPatchesAreTheAtlasAtTheRestPositions) {
  const Image<2> atlas = mixed_polarity<2>(Point<2>::Zero());
  const Template<2> t = disk_template<2>();
  const double angle = 0.3, scale = 1.1;
  Eigen::Matrix2d l;
  l << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  l *= scale;
  const Point<2> move(0.7, -0.4);
  PointList<2> q;
  std::vector<int> ids;
  const int n = t.num_vertices();
  for (int i = 0; i < n; ++i) {
    q.push_back(l * t.positions[i] + move);
    ids.push_back(i);
    if (i == 5) {  // a free vertex at the midpoint of the edge (5, 6)
      q.push_back(l * (0.5 * (t.positions[5] + t.positions[6])) + move);
      ids.push_back(-1);
    }
  }
  const Snake<2> snake(q, Connectivity::polygon(n + 1), ids);
  PatchEnergy<2> energy;
  EnergyContext<2> context{&t, &atlas};
  context.reference_image = &atlas;
  energy.bind(context, snake);
  EXPECT_LT((energy.placement_linear() - l).norm(), 1e-9);
  EXPECT_LT((energy.patch_map(33) - l).norm(), 1e-12);  // template vertex 32, its neighbourhood all template vertices
  // The energy samples the atlas smoothed by its sigma (1 mm).
  const Image<2> smoothed = gaussian_blur(atlas, 1.0);  // the same blur, same bits
  for (int v : {0, 6, 7}) {  // template vertex 0, the free vertex (index 6), template vertex 6
    const Point<2> p = v == 6 ? rest_positions(t, snake).positions[6] : t.positions[v == 7 ? 6 : 0];
    if (v == 6) {
      EXPECT_NEAR(p.norm(), 10.0, 0.01);  // on the template's circle, not its chord
    }
    // Each vertex's local map is the copy's linear part, within 2e-3 where its neighbourhood holds
    // the free vertex, whose rest position lies on the circle, off the copied chord.
    EXPECT_LT((energy.patch_map(v) - l).norm(), 2e-3);
    const Eigen::Matrix2d back = energy.patch_map(v).inverse();
    std::vector<double> e;
    for (int k = 0; k < int(energy.expected()[v].size()); ++k)
      e.push_back(smoothed.sample(p + back * (energy.sampling_step() * patch_offset<2>(k, energy.half_width()))));
    double mean = 0.0;
    for (double x : e) mean += x;
    mean /= double(e.size());
    double norm = 0.0;
    for (double& x : e) norm += (x - mean) * (x - mean);
    norm = std::sqrt(norm);
    const double tolerance = v == 6 ? 1e-9 : 0.0;  // exact at template vertices
    for (size_t k = 0; k < e.size(); ++k) EXPECT_NEAR(energy.expected()[v][k], (e[k] - mean) / norm, tolerance + 1e-15);
  }
}

// Without an atlas: the profile force with one polarity per vertex (local_polarity) follows the
// mixed-polarity disk from a start 1.5 mm outside all round: mean distance to the edge 0.17 mm,
// largest 1.4 mm (where the contrast flips), against 0.34 and 3.8 mm with one polarity for all
// ("auto", whose wrong-polarity half is pushed off).
TEST(ProfileLocalPolarity, FollowsABoundaryWhoseContrastChangesSide) {
  const Image<2> image = mixed_polarity<2>(Point<2>::Zero());
  const Template<2> t = round_template<2>(11.5, Point<2>::Zero(), 64);
  double mean[2], worst[2];
  for (int local : {0, 1}) {
    ProfileOptions o;
    o.local_polarity = local == 1;
    o.search = 3.0;
    o.length = 2.0;
    ProfileEnergy<2> energy(o);
    Snake<2> snake = Snake<2>::from_template(t, t.positions);
    iterate_alone<2>(energy, EnergyContext<2>{&t, &image}, snake, 60);
    std::tie(mean[local], worst[local]) = radial_error(snake, 10.0);
  }
  std::printf("profile on the mixed-polarity disk: distance to the edge %.3f / %.3f (auto), %.3f / %.3f mm (local)\n",
              mean[0], worst[0], mean[1], worst[1]);
  EXPECT_GT(mean[0], 0.3);
  EXPECT_LT(mean[1], 0.2);
  EXPECT_LT(worst[1], worst[0]);
}

TEST(PatchEnergy, WithoutAnAtlasImageItIsRefused) {
  const Image<2> image = mixed_polarity<2>(Point<2>::Zero());
  const Template<2> t = disk_template<2>();
  const Snake<2> snake = Snake<2>::from_template(t, t.positions);
  PatchEnergy<2> energy;
  EXPECT_THROW(energy.bind(EnergyContext<2>{&t, &image}, snake), OptionError);
}

TEST(PatchEnergy, BadKeysNameTheirPath) {
  test_support::expect_refused_at<2>({{R"({"type": "patch", "radius": 0})", "energies[0].radius"},
                                      {R"({"type": "patch", "sigma": -1})", "energies[0].sigma"},
                                      {R"({"type": "patch", "spacing": -0.5})", "energies[0].spacing"},
                                      {R"({"type": "patch", "min_correlation": 1})", "energies[0].min_correlation"},
                                      {R"({"type": "patch", "damping": -1})", "energies[0].damping"},
                                      {R"({"type": "patch", "max_step": -1})", "energies[0].max_step"},
                                      {R"({"type": "patch", "step": 0})", "energies[0].step"},
                                      {R"({"type": "patch", "map_radius": -1})", "energies[0].map_radius"},
                                      {R"({"type": "patch", "contrast": "inverted"})", "energies[0].contrast"},
                                      {R"({"type": "patch", "gradient": "image"})", "energies[0].gradient"},
                                      {R"({"type": "patch", "smoothing": "scan"})", "energies[0].smoothing"},
                                      {R"({"type": "patch", "size": 3})", "energies[0].size"}});
}

// A textured mixed-polarity disk (the disk above plus a ripple of +-15 inside and out, so that
// a patch also sees along the boundary), and the same image warped by the non-uniform stretch
// phi(x, y) = (x + c x^2 / 20, y), c = 0.25: the stretch d phi_x / dx runs from 0.75 to 1.25
// across the disk. Every template vertex p's counterpart is phi(p).
double textured_disk(const Point<2>& x) {
  auto step = [](double d) { return 0.5 * std::erfc(d / (1.2 * std::sqrt(2.0))); };
  const double outside = 200.0 * step(x[0]) + 20.0 * (1.0 - step(x[0]));
  const double inside = step(x.norm() - 10.0);
  return 100.0 * inside + outside * (1.0 - inside) + 15.0 * std::sin(1.3 * x[0]) * std::sin(1.1 * x[1]);
}
constexpr double kStretch = 0.25;
Point<2> stretch(const Point<2>& x) { return Point<2>(x[0] + kStretch * x[0] * x[0] / 20.0, x[1]); }
Point<2> unstretch(const Point<2>& y) {  // the root of c x^2 / 20 + x - y = 0 nearest 0
  const double a = kStretch / 20.0;
  return Point<2>((-1.0 + std::sqrt(1.0 + 4.0 * a * y[0])) / (2.0 * a), y[1]);
}
Image<2> textured_image(bool warped) {
  Grid<2> g;
  g.size = GridIndex<2>::Constant(56);
  g.spacing = Point<2>::Constant(1.0);
  g.origin = Point<2>::Constant(-27.5);
  Image<2> image(g);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const Point<2> y = g.to_physical(g.index(l));
    image[l] = static_cast<float>(textured_disk(warped ? unstretch(y) : y));
  }
  return image;
}

// The patch that follows each vertex's local map (map_radius) finds the warped counterparts;
// one map for all (map_radius 0, a translated patch) is biased by the stretch across its radius.
// Started at phi(p) + (0.6, -0.4) mm and iterated alone: mean distance to phi(p) below 0.25 mm
// with local maps, and less than half of the single map's. (A curve's neighbours cannot show the
// stretch along its normal; the map takes the similarity's there, hence not 0.)
TEST(PatchEnergy, LocalMapsFollowANonUniformStretch) {
  const Image<2> atlas = textured_image(false), scan = textured_image(true);
  const Template<2> t = disk_template<2>();
  PointList<2> truth;
  for (const Point<2>& p : t.positions) truth.push_back(stretch(p));
  double error[2];
  for (int local : {0, 1}) {
    PatchOptions o;
    o.map_radius = local ? 6.0 : 0.0;
    PatchEnergy<2> energy(o);
    PointList<2> start = truth;
    for (Point<2>& q : start) q += Point<2>(0.6, -0.4);
    Snake<2> snake = Snake<2>::from_template(t, start);
    iterate_patch<2>(energy, t, scan, atlas, snake, 60);
    error[local] = 0.0;
    for (int v = 0; v < snake.num_vertices(); ++v) error[local] += (snake.positions()[v] - truth[v]).norm();
    error[local] /= snake.num_vertices();
    if (local) {  // along the boundary, a vertex's map stretches as phi does (vertex 8: at 45 degrees)
      const Point<2> p = t.positions[8], tangent = Point<2>(-1.0, 1.0).normalized();
      Eigen::Matrix2d jacobian = Eigen::Matrix2d::Identity();
      jacobian(0, 0) += 2.0 * kStretch * p[0] / 20.0;
      EXPECT_NEAR((energy.patch_map(8) * tangent).norm(), (jacobian * tangent).norm(), 0.02);
    }
  }
  std::printf("patch on a non-uniform stretch: mean distance to phi(p) %.3f (one map), %.3f mm (local maps)\n",
              error[0], error[1]);
  EXPECT_LT(error[1], 0.25);
  EXPECT_LT(error[1], 0.5 * error[0]);
}

// The textured disk through the anisotropic linear map M = diag(1.25, 0.8) (exact: sampled at
// M^-1 y), every template vertex p's counterpart M p; one map for all (map_radius 0: the
// placement's, M itself). Started at M p, the coarse patch (sigma 2 mm, +-4 mm) with the atlas
// smoothed in its own frame (`smoothing` image) moves off it: edges seen through M are blurred
// by 2 M^-1 in the atlas against 2 mm in the scan. With the scan's smoothing pulled back through
// the map (mapped) the vertices stay within 0.05 mm of M p on average, less than a third of the
// former's drift.
TEST(PatchEnergy, MappedSmoothingKeepsTheTruthUnderAStretch) {
  const Eigen::Matrix2d m = Eigen::Vector2d(1.25, 0.8).asDiagonal();
  const Image<2> atlas = textured_image(false);
  Image<2> scan(atlas.grid());
  for (int64_t l = 0; l < scan.num_voxels(); ++l)
    scan[l] = static_cast<float>(textured_disk(m.inverse() * scan.grid().to_physical(scan.grid().index(l))));
  const Template<2> t = disk_template<2>();
  PointList<2> truth;
  for (const Point<2>& p : t.positions) truth.push_back(m * p);
  double drift[2];
  for (PatchSmoothing smoothing : {PatchSmoothing::kImage, PatchSmoothing::kMapped}) {
    PatchOptions o;
    o.sigma = 2.0;
    o.radius = 4.0;
    o.spacing = 1.0;
    o.map_radius = 0.0;
    o.smoothing = smoothing;
    PatchEnergy<2> energy(o);
    Snake<2> snake = Snake<2>::from_template(t, truth);
    iterate_patch<2>(energy, t, scan, atlas, snake, 40);
    EXPECT_LT((energy.placement_linear() - m).norm(), 1e-9);
    double mean = 0.0;
    for (int v = 0; v < snake.num_vertices(); ++v) mean += (snake.positions()[v] - truth[v]).norm() / snake.num_vertices();
    drift[smoothing == PatchSmoothing::kMapped] = mean;
  }
  std::printf("patch through a stretch, started at the truth: mean drift %.3f mm (image), %.3f mm (mapped)\n", drift[0],
              drift[1]);
  EXPECT_LT(drift[1], 0.05);
  EXPECT_LT(drift[1], drift[0] / 3.0);
}

// With the identity map, mapped smoothing is the image's up to the quadrature: every expected
// patch correlates above 0.99995 with the default's.
TEST(PatchEnergy, MappedSmoothingEqualsTheImagesUnderTheIdentity) {
  const Image<2> atlas = textured_image(false);
  const Template<2> t = disk_template<2>();
  const Snake<2> snake = Snake<2>::from_template(t, t.positions);
  EnergyContext<2> context{&t, &atlas};
  context.reference_image = &atlas;
  PatchOptions o;
  o.sigma = 2.0;
  PatchEnergy<2> image(o);
  o.smoothing = PatchSmoothing::kMapped;
  PatchEnergy<2> mapped(o);
  image.bind(context, snake);
  mapped.bind(context, snake);
  double least = 1.0;
  for (int v = 0; v < snake.num_vertices(); ++v) {
    const std::vector<double>&a = image.expected()[v], &b = mapped.expected()[v];
    ASSERT_EQ(a.size(), b.size());
    double dot = 0.0;
    for (size_t k = 0; k < a.size(); ++k) dot += a[k] * b[k];
    least = std::min(least, dot);
    EXPECT_GT(dot, 0.99995) << v;
  }
  std::printf("mapped against image smoothing, identity map: least correlation %.6f\n", least);
}

// A thin part (a rectangle 20 mm x 2 mm: a gyrus, a fold) has both sides within map_radius of a
// vertex near its end. A vertex's map takes only its own side (rest normals within 90 degrees):
// the snake thickened to 3 mm (the top side moved up 1 mm, the end sides stretched) leaves the
// bottom side where it was, and so the map of a bottom vertex 2 mm from the end is the identity.
// Were the far side in it, the map would measure the thickening (a stretch of about 1.5 across)
// and stretch the vertex's atlas patch to match a thickening it helped make.
TEST(PatchEnergy, ALocalMapTakesOnlyItsOwnSideOfAThinPart) {
  Template<2> t;
  auto add = [&](double x, double y) { t.positions.push_back(Point<2>(x, y)); };
  for (int i = 0; i < 40; ++i) add(0.5 * i, 0.0);      // bottom, left to right (counter-clockwise)
  for (int i = 0; i < 4; ++i) add(20.0, 0.5 * i);      // right end, upwards
  for (int i = 0; i < 40; ++i) add(20.0 - 0.5 * i, 2.0);  // top, right to left
  for (int i = 0; i < 4; ++i) add(0.0, 2.0 - 0.5 * i);  // left end, downwards
  t.connectivity = Connectivity::polygon(t.num_vertices());
  PointList<2> thick = t.positions;
  for (Point<2>& q : thick) q[1] *= 1.5;  // 2 mm -> 3 mm: the bottom (y = 0) stays
  const Snake<2> snake = Snake<2>::from_template(t, thick);
  Grid<2> g;
  g.size = GridIndex<2>(40, 20);
  g.spacing = Point<2>::Constant(1.0);
  g.origin = Point<2>(-10.0, -8.0);
  const Image<2> flat(g, 100.0f);
  PatchOptions o;
  o.map_radius = 6.0;
  PatchEnergy<2> energy(o);
  EnergyContext<2> context{&t, &flat};
  context.reference_image = &flat;
  energy.bind(context, snake);
  const int v = 36;  // (18, 0): 2 mm from the right end, whose far side lies within 6 mm
  ASSERT_EQ(t.positions[v], Point<2>(18.0, 0.0));
  EXPECT_LT((energy.patch_map(v) - Eigen::Matrix2d::Identity()).norm(), 1e-9) << energy.patch_map(v);
}

// Where the atlas is flat (no appearance to match) every vertex holds: the proposal is exactly
// where it stands, never an undefined move.
TEST(PatchEnergy, AFlatAtlasGivesNoMove) {
  const Image<3> scan = mixed_polarity<3>(Point<3>::Zero());
  Image<3> atlas(scan.grid(), 100.0f);
  const Template<3> t = disk_template<3>();
  PointList<3> start = t.positions;
  for (Point<3>& p : start) p += Point<3>(0.7, -0.3, 0.2);
  const Snake<3> snake = Snake<3>::from_template(t, start);
  PatchEnergy<3> energy;
  EnergyContext<3> context{&t, &scan};
  context.reference_image = &atlas;
  energy.bind(context, snake);
  PointList<3> out(snake.num_vertices(), Point<3>::Constant(std::nan("")));
  energy.propose(snake, out);
  for (int v = 0; v < snake.num_vertices(); ++v) {
    EXPECT_TRUE(energy.expected()[v].empty());
    EXPECT_EQ(out[v], start[v]) << v;
  }
}

TEST(PatchEnergy, SameBitsForOneAndTwoThreads) {
  const Image<3> atlas = mixed_polarity<3>(Point<3>::Zero());
  const Image<3> scan = mixed_polarity<3>(Point<3>(1.0, 0.5, -0.5));
  const Template<3> t = disk_template<3>();
  // Started stretched (1.1 along x) so that the local maps change and the patches are resampled.
  PointList<3> start = t.positions;
  for (Point<3>& p : start) p[0] *= 1.1;
  PointList<3> result[2];
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    Snake<3> snake = Snake<3>::from_template(t, start);
    PatchEnergy<3> energy;
    iterate_patch<3>(energy, t, scan, atlas, snake, 5);
    result[threads - 1] = snake.positions();
    // Some patches were resampled: their maps moved by more than the tolerance since the bind.
    PatchEnergy<3> at_start;
    EnergyContext<3> context{&t, &scan};
    context.reference_image = &atlas;
    at_start.bind(context, Snake<3>::from_template(t, start));
    double changed = 0.0;
    for (int v = 0; v < snake.num_vertices(); ++v)
      changed = std::max(changed, (energy.patch_map(v) - at_start.patch_map(v)).cwiseAbs().maxCoeff());
    EXPECT_GT(changed, 0.01);
  }
  omp_set_num_threads(2);
  for (size_t v = 0; v < result[0].size(); ++v) EXPECT_EQ(result[0][v], result[1][v]);
}

}  // namespace
}  // namespace dsnake
