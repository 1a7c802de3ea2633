// Tests of the figure writers: each figure is read back with OpenCV and its pixels are checked
// at the places where the geometry says the shapes must be drawn.
#include "experiments/output/figures.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

// A fresh folder per test; the PNGs stay there for a look (gtest's TempDir, usually /tmp).
fs::path output_folder(const std::string& test) {
  const fs::path dir = fs::path(::testing::TempDir()) / "dsnake_figures_test" / test;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Regular n-gon of radius r around c (counter-clockwise, vertex 0 on the +x side).
PointList<2> circle(int n, const Point<2>& c, double r) {
  PointList<2> p;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * std::numbers::pi * i / n;
    p.push_back(c + r * Point<2>(std::cos(t), std::sin(t)));
  }
  return p;
}

// Icosahedron subdivided `levels` times (midpoints), projected onto the sphere (c, r).
Template<3> icosphere(int levels, const Point<3>& c, double r) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  PointList<3> p = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                    {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  std::vector<Triangle> t = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                             {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                             {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (auto& x : p) x.normalize();
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto [it, added] = mid.try_emplace(key, static_cast<int>(p.size()));
      if (added) p.push_back((p[a] + p[b]).normalized());
      return it->second;
    };
    std::vector<Triangle> finer;
    for (const auto& f : t) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.insert(finer.end(), {{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}});
    }
    t = std::move(finer);
  }
  Template<3> tmpl;
  for (const auto& x : p) tmpl.positions.push_back(c + r * x);
  tmpl.connectivity = Connectivity::mesh(static_cast<int>(p.size()), std::move(t));
  return tmpl;
}

// Image whose voxel centres are at origin + index * spacing, with a smooth blob in the middle so
// the background is not flat.
template <int D>
Image<D> blob_image(const GridIndex<D>& size, const Point<D>& spacing, const Point<D>& origin = Point<D>::Zero()) {
  Grid<D> grid;
  grid.size = size;
  grid.spacing = spacing;
  grid.origin = origin;
  Image<D> img(grid);
  const Point<D> mid = origin + 0.5 * (size.template cast<double>() - Point<D>::Ones()).cwiseProduct(spacing);
  for (int64_t i = 0; i < img.num_voxels(); ++i) {
    const double d = (grid.to_physical(grid.index(i)) - mid).norm();
    img[i] = static_cast<float>(100.0 + 80.0 * std::exp(-d * d / 800.0));
  }
  return img;
}

// Colour classes of a BGR pixel, tolerant to antialiasing against a grey background.
bool is_yellow(const cv::Vec3b& p) { return p[2] > 180 && p[1] > 140 && p[0] < 110; }
bool is_red(const cv::Vec3b& p) { return p[2] > 150 && p[1] < 110 && p[0] < 110 && p[2] - p[1] > 80; }
bool is_green(const cv::Vec3b& p) { return p[1] > 150 && p[2] < 120 && p[0] < 120; }
bool is_grey(const cv::Vec3b& p) { return p[0] == p[1] && p[1] == p[2]; }

// True when some pixel within +-band px of radius r px from c along angle t has the colour.
template <typename Pred>
bool colour_on_ray(const cv::Mat& img, const Eigen::Vector2d& c, double r, double t, double band, Pred pred) {
  for (double s = r - band; s <= r + band; s += 0.5) {
    const int x = static_cast<int>(std::lround(c.x() + s * std::cos(t)));
    const int y = static_cast<int>(std::lround(c.y() + s * std::sin(t)));
    if (x >= 0 && y >= 0 && x < img.cols && y < img.rows && pred(img.at<cv::Vec3b>(y, x))) return true;
  }
  return false;
}

TEST(Figures, OverlayDrawsTemplateYellowAndResultRed) {
  const Image<2> img = blob_image<2>({100, 100}, {1.0, 1.0});
  const Point<2> centre(49.5, 49.5);  // centre of the voxel centres 0..99
  const PointList<2> inner = circle(80, centre, 20.0), outer = circle(120, centre, 35.0);
  const Connectivity ci = Connectivity::polygon(80), co = Connectivity::polygon(120);
  const fs::path png = output_folder("overlay") / "overlay.png";
  write_overlay_figure(img, {{inner, ci, kTemplateYellow, {0, 20}}, {outer, co, kResultRed}}, png.string());

  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  // 100 voxels -> factor ceil(512 / 100) = 6; no title or legend, so no frame.
  ASSERT_EQ(out.cols, 600);
  ASSERT_EQ(out.rows, 600);
  const Eigen::Vector2d c_px(299.5, 299.5);  // (49.5 + 0.5) * 6 - 0.5
  for (double deg : {10.0, 45.0, 100.0, 135.0, 200.0, 250.0, 300.0, 330.0}) {
    const double t = deg * std::numbers::pi / 180.0;
    EXPECT_TRUE(colour_on_ray(out, c_px, 20.0 * 6, t, 3.0, is_yellow)) << "template at " << deg << " deg";
    EXPECT_TRUE(colour_on_ray(out, c_px, 35.0 * 6, t, 3.0, is_red)) << "result at " << deg << " deg";
    EXPECT_TRUE(colour_on_ray(out, c_px, 27.5 * 6, t, 0.0, is_grey)) << "between the circles at " << deg;
  }
  EXPECT_TRUE(is_grey(out.at<cv::Vec3b>(300, 300)));
  EXPECT_GT(out.at<cv::Vec3b>(300, 300)[0], 200);  // the blob's bright centre: window maps max to ~255
  // Marked vertices 0 (angle 0) and 20 (90 degrees, y down) are green dots on the template.
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(300, 300 + 120)));
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(300 + 120, 300)));
}

bool is_cyan(const cv::Vec3b& p) { return p[0] > 180 && p[1] > 120 && p[2] < 90; }  // kTruthCyan, BGR

// A disc mask of radius r (physical units) around c on `grid`.
template <int D>
BinaryMask<D> ball_mask(const Grid<D>& grid, const Point<D>& c, double r) {
  std::vector<uint8_t> inside(size_t(grid.num_voxels()));
  for (int64_t i = 0; i < grid.num_voxels(); ++i) inside[size_t(i)] = (grid.to_physical(grid.index(i)) - c).norm() <= r;
  return BinaryMask<D>(grid, std::move(inside));
}

// The truth as a mask is outlined in cyan where its boundary is (between inside and outside
// pixel centres), under the shapes, and appears in the legend; nowhere else is cyan.
TEST(Figures, OverlayOutlinesAMaskLayerAtItsBoundary) {
  const Image<2> img = blob_image<2>({100, 100}, {1.0, 1.0});
  const Point<2> centre(49.5, 49.5);
  // The mask on a grid of its own (half the spacing, shifted): sampled at the image's voxels.
  Grid<2> mask_grid;
  mask_grid.size = {200, 200};
  mask_grid.spacing = {0.5, 0.5};
  mask_grid.origin = {0.25, 0.25};
  const BinaryMask<2> truth = ball_mask<2>(mask_grid, centre, 30.0);
  const PointList<2> ring = circle(80, centre, 15.0);
  const Connectivity c = Connectivity::polygon(80);
  const fs::path png = output_folder("overlay_truth") / "overlay.png";
  write_overlay_figure(img, {{ring, c, kResultRed}}, png.string(), "", {{truth, kTruthCyan, "ground truth"}});
  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  // A legend band: the panel (600 x 600) starts at the margin.
  const Eigen::Vector2d c_px(12 + 299.5, 12 + 299.5);
  for (double deg = 0; deg < 360; deg += 15) {
    const double t = deg * std::numbers::pi / 180.0;
    EXPECT_TRUE(colour_on_ray(out, c_px, 30.0 * 6, t, 6.0, is_cyan)) << "truth at " << deg << " deg";
    EXPECT_TRUE(colour_on_ray(out, c_px, 15.0 * 6, t, 3.0, is_red)) << "result at " << deg << " deg";
    EXPECT_FALSE(colour_on_ray(out, c_px, 22.0 * 6, t, 30.0, is_cyan)) << "inside the truth at " << deg << " deg";
    EXPECT_FALSE(colour_on_ray(out, c_px, 40.0 * 6, t, 30.0, is_cyan)) << "outside the truth at " << deg << " deg";
  }
}

bool is_link_green(const cv::Vec3b& p) { return p[1] > 120 && p[1] - p[2] > 50 && p[1] - p[0] > 35; }  // kLinkGreen, BGR

// The correspondence links: a segment from each template vertex to where it landed, and nothing
// between them; the legend names them.
TEST(Figures, OverlayJoinsEachTemplateVertexToWhereItLanded) {
  const Image<2> img = blob_image<2>({100, 100}, {1.0, 1.0});
  const Point<2> centre(49.5, 49.5);
  const PointList<2> inner = circle(8, centre, 10.0), outer = circle(8, centre, 25.0);
  const Connectivity c = Connectivity::polygon(8);
  std::vector<std::array<Point<2>, 2>> links;
  for (int i = 0; i < 8; ++i) links.push_back({inner[i], outer[i]});
  const fs::path png = output_folder("overlay_links") / "overlay.png";
  write_overlay_figure(img, {{inner, c, kTemplateYellow}, {outer, c, kResultRed}}, png.string(), "", {}, links);
  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  const Eigen::Vector2d c_px(12 + 299.5, 12 + 299.5);  // framed by the legend: 600 x 600 at the margin
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector2d d = (outer[i] - centre).normalized();
    const double t = std::atan2(d.y(), d.x());
    EXPECT_TRUE(colour_on_ray(out, c_px, 17.5 * 6, t, 1.0, is_link_green)) << "link " << i;
    EXPECT_FALSE(colour_on_ray(out, c_px, 17.5 * 6, t + std::numbers::pi / 8, 20.0, is_link_green)) << "between " << i;
  }
  int legend_green = 0;
  for (int y = 12 + 600; y < out.rows; ++y)
    for (int x = 0; x < 60; ++x) legend_green += is_link_green(out.at<cv::Vec3b>(y, x));
  EXPECT_GT(legend_green, 10);
}

TEST(Figures, OverlayKeepsPhysicalAspectForAnisotropicSpacing) {
  const Image<2> img = blob_image<2>({100, 100}, {1.0, 2.0});  // 100 x 200 physical units
  const Point<2> centre(49.5, 99.0);
  const PointList<2> ring = circle(120, centre, 40.0);
  const Connectivity c = Connectivity::polygon(120);
  const fs::path png = output_folder("anisotropic") / "anisotropic.png";
  write_overlay_figure(img, {{ring, c, kResultRed}}, png.string());

  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  EXPECT_NEAR(static_cast<double>(out.rows) / out.cols, 2.0, 0.01);
  EXPECT_GE(std::max(out.rows, out.cols), 512);
  // A physical circle stays a circle: 40 units are 120 px along x and along y.
  const double px = static_cast<double>(out.cols) / 100.0;  // pixels per physical unit
  const Eigen::Vector2d c_px((49.5 + 0.5) * px - 0.5, (99.0 / 2.0 + 0.5) * 2.0 * px - 0.5);
  for (double deg : {0.0, 90.0, 180.0, 270.0, 45.0})
    EXPECT_TRUE(colour_on_ray(out, c_px, 40.0 * px, deg * std::numbers::pi / 180.0, 3.0, is_red)) << deg;
}

TEST(Figures, OverlayAddsTitleAndLegendBands) {
  const Image<2> img = blob_image<2>({64, 48}, {1.0, 1.0});
  const PointList<2> ring = circle(40, Point<2>(32, 24), 10.0);
  const Connectivity c = Connectivity::polygon(40);
  const fs::path png = output_folder("title") / "title.png";
  write_overlay_figure(img, {{.points = ring, .connectivity = c, .rgb = kTemplateYellow, .label = "template"}},
                       png.string(), "Star, clean");
  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  // 64 voxels -> factor 8: 512 x 384 plus margins, a title band and a legend band.
  EXPECT_GT(out.cols, 512);
  EXPECT_GT(out.rows, 384 + 40);
  int dark_top = 0, yellow_bottom = 0;
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < out.cols; ++x) dark_top += out.at<cv::Vec3b>(y, x)[0] < 100;
  for (int y = out.rows - 30; y < out.rows; ++y)
    for (int x = 0; x < 60; ++x) yellow_bottom += is_yellow(out.at<cv::Vec3b>(y, x));
  EXPECT_GT(dark_top, 20) << "title text";
  EXPECT_GT(yellow_bottom, 10) << "legend line sample";
}

// Red pixels of a slice figure above row `end_row` (to leave out a legend band), grouped into
// panels (columns separated by a gap of > 40 px).
std::vector<std::vector<Eigen::Vector2d>> red_pixels_by_panel(const cv::Mat& img, int end_row) {
  std::vector<std::vector<Eigen::Vector2d>> panels;
  int last_x = -1000;
  for (int x = 0; x < img.cols; ++x)
    for (int y = 0; y < end_row; ++y) {
      if (!is_red(img.at<cv::Vec3b>(y, x))) continue;
      if (x - last_x > 40) panels.emplace_back();
      panels.back().emplace_back(x, y);
      last_x = x;
    }
  return panels;
}

// Centre of the bounding box of a set of pixels.
Eigen::Vector2d box_centre(const std::vector<Eigen::Vector2d>& px) {
  Eigen::Vector2d lo = px[0], hi = px[0];
  for (const auto& p : px) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return 0.5 * (lo + hi);
}

// Both volumes span 64 physical units per axis: 8 px per unit on every panel.
class SliceFigure : public ::testing::TestWithParam<bool> {};

TEST_P(SliceFigure, ShowsMeshCrossSectionsAtTheRightRadius) {
  const bool anisotropic = GetParam();  // 64 x 64 x 32 voxels of 1 x 1 x 2, shifted origin
  const Point<3> origin = anisotropic ? Point<3>(-10, 5, 3) : Point<3>::Zero();
  const Image<3> volume = anisotropic ? blob_image<3>({64, 64, 32}, {1, 1, 2}, origin)
                                      : blob_image<3>({64, 64, 64}, {1, 1, 1});
  const Point<3> centre = origin + Point<3>(32, 32, 32);  // a voxel centre on both grids
  const Template<3> result = icosphere(2, centre, 20.0);
  const Template<3> initial = icosphere(1, centre, 10.0);
  ASSERT_EQ(result.connectivity.closed_manifold_problem(), "");
  const fs::path png = output_folder(anisotropic ? "slices_anisotropic" : "slices") / "slices.png";
  write_slice_figure(volume,
                     {{initial.positions, initial.connectivity, kTemplateYellow, {0, 1, 2, 3}, "template"},
                      {result.positions, result.connectivity, kResultRed, {}, "result"}},
                     centre, png.string(), "icosphere, r = 20");

  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  const auto panels = red_pixels_by_panel(out, out.rows - 40);  // the legend is in the last rows
  ASSERT_EQ(panels.size(), 3u);
  const double scale = 8.0;  // 64 units -> ceil(512 / 64) = 8 px per unit
  for (size_t k = 0; k < panels.size(); ++k) {
    const Eigen::Vector2d c = box_centre(panels[k]);
    std::array<int, 16> sectors{};
    for (const auto& p : panels[k]) {
      const double r = (p - c).norm();
      // The faceted sphere lies between ~19.7 and 20 units; the line is 2 px wide.
      EXPECT_GT(r, 19.0 * scale) << "panel " << k;
      EXPECT_LT(r, 20.0 * scale + 4.0) << "panel " << k;
      const double t = std::atan2(p.y() - c.y(), p.x() - c.x()) + std::numbers::pi;
      ++sectors[std::min(15, static_cast<int>(t / (2.0 * std::numbers::pi) * 16))];
    }
    for (int s = 0; s < 16; ++s) EXPECT_GT(sectors[s], 10) << "panel " << k << " sector " << s;
    // Panels share their top row. The centre's row in the panel: axial (v = y, down) voxel 32
    // of 8 px, (32 + 0.5) * 8 - 0.5; coronal and sagittal (v = z, up: row from the top = last
    // voxel - index) voxel 63 - 32 = 31 of 8 px, or 31 - 16 = 15 of 16 px.
    const double row_in_panel = k == 0 ? 259.5 : !anisotropic ? (31 + 0.5) * 8 - 0.5 : (15 + 0.5) * 16 - 0.5;
    EXPECT_NEAR(c.y() - box_centre(panels[0]).y(), row_in_panel - 259.5, 1.0) << "panel " << k;
  }
}

INSTANTIATE_TEST_SUITE_P(Figures, SliceFigure, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "Anisotropic" : "Isotropic"; });

TEST(Figures, SlicesOutlineAMaskLayerInEachPanel) {
  const Image<3> volume = blob_image<3>({64, 64, 64}, {1, 1, 1});
  const Point<3> centre(32, 32, 32);
  const BinaryMask<3> truth = ball_mask<3>(volume.grid(), centre, 20.0);
  const Template<3> result = icosphere(2, centre, 10.0);
  const fs::path png = output_folder("slices_truth") / "slices.png";
  write_slice_figure(volume, {{result.positions, result.connectivity, kResultRed, {}, "result"}}, centre, png.string(),
                     "truth", {{truth, kTruthCyan, "ground truth"}});
  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  // Cyan pixels by panel (columns split by white gaps), above the legend: each panel's outline
  // is a circle of radius ~20 units (8 px a unit) around the red circle's centre.
  const auto red = red_pixels_by_panel(out, out.rows - 40);
  ASSERT_EQ(red.size(), 3u);
  for (size_t k = 0; k < red.size(); ++k) {
    const Eigen::Vector2d c = box_centre(red[k]);
    int found = 0, stray = 0;
    for (int y = 0; y < out.rows - 40; ++y)
      for (int x = 0; x < out.cols; ++x) {
        if (!is_cyan(out.at<cv::Vec3b>(y, x))) continue;
        if (std::abs(x - c.x()) > 250 || std::abs(y - c.y()) > 250) continue;  // another panel's
        const double r = (Eigen::Vector2d(x, y) - c).norm();
        if (r > 19.0 * 8 && r < 21.0 * 8 + 4) ++found;
        else if (r < 17.0 * 8) ++stray;
      }
    EXPECT_GT(found, 500) << "panel " << k;
    EXPECT_EQ(stray, 0) << "panel " << k;
  }
}

TEST(Figures, SlicesHandleVerticesAndEdgesLyingOnThePlane) {
  Grid<3> grid;
  grid.size = {40, 40, 40};
  const Image<3> volume(grid, 1.0f);  // flat volume: mid grey
  const Point<3> c(20, 20, 20);
  // Octahedron: on each slice plane through c, four vertices and four edges lie in the plane.
  PointList<3> p = {c + Point<3>(12, 0, 0), c - Point<3>(12, 0, 0), c + Point<3>(0, 12, 0),
                    c - Point<3>(0, 12, 0), c + Point<3>(0, 0, 12), c - Point<3>(0, 0, 12)};
  const Connectivity oct = Connectivity::mesh(6, {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                  {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}});
  ASSERT_EQ(oct.closed_manifold_problem(), "");
  const fs::path png = output_folder("octahedron") / "octahedron.png";
  write_slice_figure(volume, {{p, oct, kResultRed}}, c, png.string());

  const cv::Mat out = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(out.empty());
  const auto panels = red_pixels_by_panel(out, out.rows);
  ASSERT_EQ(panels.size(), 3u);
  const double scale = 13.0;  // 40 voxels -> ceil(512 / 40) = 13 px per voxel
  for (const auto& panel : panels) {
    const Eigen::Vector2d m = box_centre(panel);
    // The cross-section is the square |u| + |v| = 12: corners at 12 units, edge midpoints at 6 * sqrt(2).
    for (double deg : {0.0, 90.0, 180.0, 270.0})
      EXPECT_TRUE(colour_on_ray(out, m, 12.0 * scale, deg * std::numbers::pi / 180.0, 3.0, is_red));
    for (double deg : {45.0, 135.0, 225.0, 315.0})
      EXPECT_TRUE(colour_on_ray(out, m, 6.0 * std::sqrt(2.0) * scale, deg * std::numbers::pi / 180.0, 2.0, is_red));
    EXPECT_TRUE(is_grey(out.at<cv::Vec3b>(static_cast<int>(m.y()), static_cast<int>(m.x()))));
  }
}

// The panels' labels: the anatomical view and the slice's world coordinate on an axis-aligned
// volume; on an oblique one, the grid plane and the world point it passes through.
TEST(Figures, SliceLabelsGiveWorldPositionsAlsoOnAnObliqueScan) {
  Grid<3> g;
  g.size = {10, 12, 8};
  g.spacing = {1.0, 2.0, 0.5};
  g.origin = {-5.0, 10.0, 3.0};
  const GridIndex<3> at(2, 3, 4);
  EXPECT_EQ(slice_label(g, at, 2), "axial  z = 5 mm  (x right = L, y down = P)");
  EXPECT_EQ(slice_label(g, at, 1), "coronal  y = 16 mm  (x right = L, z up = S)");
  EXPECT_EQ(slice_label(g, at, 0), "sagittal  x = -3 mm  (y right = P, z up = S)");
  g.direction = Eigen::AngleAxisd(0.5 * 3.14159265358979323846, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  // Voxel (2, 3, 4) at frame offset (2, 6, 2) from the origin, turned 90 degrees about z: (-6, 2, 2).
  EXPECT_EQ(slice_label(g, at, 1), "grid y plane through (-11, 12, 5) mm");
}

TEST(Figures, UnwritablePathThrowsNamingItAndLeavesNoFile) {
  const fs::path dir = output_folder("unwritable");
  const Image<2> img = blob_image<2>({20, 20}, {1.0, 1.0});
  const std::string missing = (dir / "missing" / "figure.png").string();
  try {
    write_overlay_figure(img, {}, missing);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(missing));
  // The final name is taken by a folder: the rename fails and the temporary file is removed.
  fs::create_directory(dir / "taken.png");
  EXPECT_THROW(write_overlay_figure(img, {}, (dir / "taken.png").string()), std::runtime_error);
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1) << "only the folder taken.png";
}

}  // namespace
}  // namespace dsnake
