// GradientField on synthetic images: the force points at the edge of a disk and vanishes on it,
// the potential is minimal there, a ramp gives no interior force, the field is spacing-aware and
// independent of the thread count; and the field registry's error messages.
#include "fields/gradient.h"
#include "fields/registry.h"
#include "framework/core/errors.h"

#include <cmath>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <omp.h>

namespace dsnake {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A disk of radius 20 (value 1 inside, 0 outside, partial-volume by 4x4 supersampling) centred
// in a 64 x 64 image of unit spacing.
Image<2> disk_image(const Point<2>& centre, double radius) {
  Grid<2> grid;
  grid.size = GridIndex<2>(64, 64);
  Image<2> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const Point<2> x = grid.to_physical(grid.index(l));
    int inside = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        inside += (x + Point<2>((i - 1.5) / 4, (j - 1.5) / 4) - centre).norm() < radius;
    image[l] = inside / 16.0f;
  }
  return image;
}

// Mean of g over points at distance r from centre.
template <class G>
double mean_on_circle(const Point<2>& centre, double r, G g) {
  double sum = 0;
  for (int k = 0; k < 64; ++k) {
    const double t = 2 * kPi * k / 64;
    sum += g(centre + r * Point<2>(std::cos(t), std::sin(t)), Point<2>(std::cos(t), std::sin(t)));
  }
  return sum / 64;
}

TEST(GradientField, ForcePointsToDiskEdge) {
  const Point<2> centre(32.3, 31.6);
  GradientField<2> field({3.0, true});
  field.compute(disk_image(centre, 20.0));
  for (int k = 0; k < 32; ++k) {
    const double t = 2 * kPi * k / 32;
    const Point<2> dir(std::cos(t), std::sin(t));
    EXPECT_GT(field.force(centre + 14.0 * dir, dir).dot(dir), 0.0) << "inside, angle " << t;
    EXPECT_LT(field.force(centre + 26.0 * dir, dir).dot(dir), 0.0) << "outside, angle " << t;
  }
  auto magnitude = [&](const Point<2>& x, const Point<2>&) { return field.force(x, x).norm(); };
  const double on_edge = mean_on_circle(centre, 20.0, magnitude);
  EXPECT_LT(on_edge, 0.5 * mean_on_circle(centre, 18.0, magnitude));
  EXPECT_LT(on_edge, 0.5 * mean_on_circle(centre, 22.0, magnitude));
}

TEST(GradientField, PotentialIsMinimalAtDiskEdge) {
  const Point<2> centre(32.3, 31.6);
  GradientField<2> field({2.0, true});
  field.compute(disk_image(centre, 20.0));
  ASSERT_TRUE(field.has_potential());
  double best_r = 0, best_p = 1e9;
  for (double r = 5.0; r <= 29.0; r += 0.05) {
    const double p = mean_on_circle(centre, r, [&](const Point<2>& x, const Point<2>&) {
      return field.potential(x);
    });
    if (p < best_p) best_p = p, best_r = r;
  }
  EXPECT_NEAR(best_r, 20.0, 1.0);
  // Normalised: P = 1 - f >= 0, and close to 0 at the edge.
  EXPECT_GE(best_p, 0.0);
  EXPECT_LT(best_p, 0.2);
  EXPECT_GT(field.potential(centre), 0.99);
}

TEST(GradientField, RampHasConstantEdgeMapAndNoInteriorForce) {
  Grid<2> grid;
  grid.size = GridIndex<2>(40, 30);
  grid.spacing = Point<2>(0.5, 2.0);
  Image<2> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const Point<2> x = grid.to_physical(grid.index(l));
    image[l] = static_cast<float>(2.0 * x.x() + 3.0 * x.y());
  }
  GradientField<2> field({1.0, false});
  field.compute(image);
  // Away from the borders (3 sigma of blur + the difference stencils): f = |(2, 3)|^2 = 13.
  for (int j = 0; j < 30; ++j)
    for (int i = 0; i < 40; ++i) {
      const GridIndex<2> idx(i, j);
      if (i < 9 || i > 30 || j < 4 || j > 25) continue;
      EXPECT_NEAR(field.edge_map().at(idx), 13.0, 1e-4) << i << "," << j;
      EXPECT_NEAR(field.vectors()[grid.linear(idx)].norm(), 0.0, 1e-6) << i << "," << j;
    }
}

// A ball of radius 12 mm centred at (20, 20, 20) mm with a smooth (logistic, 2 mm) edge,
// sampled on a 40 x 40 x nz grid of the given z spacing.
Image<3> ball_image(double z_spacing) {
  Grid<3> grid;
  grid.spacing = Point<3>(1.0, 1.0, z_spacing);
  grid.size = GridIndex<3>(41, 41, int(std::floor(40.0 / z_spacing)) + 1);
  Image<3> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l) {
    const double r = (grid.to_physical(grid.index(l)) - Point<3>(20, 20, 20)).norm();
    image[l] = static_cast<float>(1.0 / (1.0 + std::exp((r - 12.0) / 2.0)));
  }
  return image;
}

// Peak of the edge map along the line from the centre in direction `axis`: the best voxel,
// refined by a parabola through it and its neighbours. Returns (radius in mm, peak value).
std::pair<double, double> edge_peak(const GradientField<3>& field, int axis) {
  const Grid<3>& grid = field.edge_map().grid();
  GridIndex<3> idx = grid.to_continuous_index(Point<3>(20, 20, 20)).array().round().cast<int>();
  const int c = idx[axis];
  int best = c;
  for (int i = c; i < grid.size[axis]; ++i) {
    GridIndex<3> a = idx, b = idx;
    a[axis] = i, b[axis] = best;
    if (field.edge_map().at(a) > field.edge_map().at(b)) best = i;
  }
  auto f = [&](int i) { GridIndex<3> a = idx; a[axis] = i; return double(field.edge_map().at(a)); };
  const double fm = f(best - 1), f0 = f(best), fp = f(best + 1);
  const double offset = 0.5 * (fm - fp) / (fm - 2 * f0 + fp);
  const double h = grid.spacing[axis];
  return {(best + offset - c) * h, f0 - 0.25 * (fm - fp) * offset};
}

TEST(GradientField, SpacingAware3d) {
  GradientFieldOptions o{1.5, false};
  GradientField<3> iso(o), aniso(o);
  iso.compute(ball_image(1.0));
  aniso.compute(ball_image(2.5));
  const auto [r_iso_z, f_iso_z] = edge_peak(iso, 2);
  const auto [r_aniso_z, f_aniso_z] = edge_peak(aniso, 2);
  const auto [r_aniso_x, f_aniso_x] = edge_peak(aniso, 0);
  EXPECT_NEAR(r_iso_z, r_aniso_z, 1.0);
  EXPECT_NEAR(r_aniso_x, r_aniso_z, 1.0);
  // The same physical gradient along z and x, and on both grids (|grad I|^2 in 1/mm^2).
  EXPECT_NEAR(f_aniso_z / f_iso_z, 1.0, 0.2);
  EXPECT_NEAR(f_aniso_z / f_aniso_x, 1.0, 0.2);
  // The force is grad f in 1/mm: along z on the anisotropic grid, the central differences
  // telescope, sum_{i=c+1}^{p-1} F_z(i) h_z = (f_p + f_{p-1} - f_{c+1} - f_c) / 2.
  const Grid<3>& grid = aniso.edge_map().grid();
  const GridIndex<3> centre(20, 20, 8);
  ASSERT_EQ(grid.to_physical(centre), Point<3>(20, 20, 20));
  auto at = [&](int k) { GridIndex<3> i = centre; i[2] = k; return grid.linear(i); };
  const int p = 13;  // z = 32.5 mm, just past the edge
  double integral = 0;
  for (int k = 9; k < p; ++k) integral += aniso.vectors()[at(k)].z() * grid.spacing.z();
  const auto& f = aniso.edge_map();
  const double telescoped = 0.5 * (f[at(p)] + f[at(p - 1)] - f[at(9)] - f[at(8)]);
  EXPECT_NEAR(integral, telescoped, 1e-5 * std::abs(telescoped));
  EXPECT_GT(telescoped, 0.1 * f_aniso_z);
  const Point<3> inside(20, 20, 20 + 9.0), outside(20, 20, 20 + 15.0);
  EXPECT_GT(aniso.force(inside, inside).z(), 0.0);
  EXPECT_LT(aniso.force(outside, outside).z(), 0.0);
}

TEST(GradientField, IndependentOfThreadCount) {
  const int threads = omp_get_max_threads();
  const Image<3> image = ball_image(2.5);
  GradientField<3> one({1.5, true}), two({1.5, true});
  omp_set_num_threads(1);
  one.compute(image);
  omp_set_num_threads(2);
  two.compute(image);
  omp_set_num_threads(threads);
  ASSERT_EQ(one.vectors().num_voxels(), two.vectors().num_voxels());
  for (int64_t l = 0; l < one.vectors().num_voxels(); ++l) {
    ASSERT_EQ(one.vectors()[l], two.vectors()[l]) << l;
    ASSERT_EQ(one.edge_map()[l], two.edge_map()[l]) << l;
  }
}

TEST(GradientField, ZeroImageGivesZeroField) {
  Grid<2> grid;
  grid.size = GridIndex<2>(8, 8);
  GradientField<2> field;
  field.compute(Image<2>(grid, 5.0f));
  EXPECT_EQ(field.force(Point<2>(3, 3), Point<2>::Zero()), Point<2>::Zero());
  EXPECT_EQ(field.potential(Point<2>(3, 3)), 0.0);
}

// --- field registry --------------------------------------------------------------------------

std::string error_of(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text);
  JsonReader reader(j, "exp.json", "field");
  try {
    field_registry<3>().create(reader);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(FieldRegistry, CreatesWithOptions) {
  const nlohmann::json j = nlohmann::json::parse(R"({"type": "gradient", "sigma": 2.5, "normalize": false})");
  JsonReader reader(j, "exp.json", "field");
  auto field = field_registry<2>().create(reader);
  auto* gradient = dynamic_cast<GradientField<2>*>(field.get());
  ASSERT_NE(gradient, nullptr);
  EXPECT_EQ(gradient->options().sigma, 2.5);
  EXPECT_FALSE(gradient->options().normalize);
}

TEST(FieldRegistry, ErrorsNameThePath) {
  const std::string unknown = error_of(R"({"type": "gvf_typo"})");
  EXPECT_NE(unknown.find("field.type"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("gradient"), std::string::npos) << unknown;
  EXPECT_NE(error_of(R"({"type": "gradient", "foo": 1})").find("field.foo"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "gradient", "sigma": "x"})").find("field.sigma"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "gradient", "sigma": -1})").find("field.sigma"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "gradient", "normalize": 1})").find("field.normalize"), std::string::npos);
}

}  // namespace
}  // namespace dsnake
