#include "experiments/output/figures.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/io/raster_codecs.h"
#include "meshing/surface_extraction.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace dsnake {

namespace {

constexpr int kMinLongSidePx = 512;  // the upscaled image's longer side is at least this
constexpr int kLineWidthPx = 2;
constexpr int kDotRadiusPx = 5;
constexpr int kShiftBits = 4;  // sub-pixel precision of OpenCV drawing: coordinates * 16
constexpr double kShiftScale = 1 << kShiftBits;
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.6;
constexpr int kMarginPx = 12;  // space around panels, bands and legends
const cv::Scalar kWhite(255, 255, 255), kBlack(0, 0, 0), kLightGrey(225, 225, 225);

// OpenCV stores blue, green, red.
cv::Scalar to_bgr(const Rgb& c) { return cv::Scalar(c[2], c[1], c[0]); }

// A point in pixel coordinates (pixel centres at integers) in OpenCV's fixed-point form.
cv::Point fixed_point(const Eigen::Vector2d& px) {
  return {static_cast<int>(std::lround(px.x() * kShiftScale)),
          static_cast<int>(std::lround(px.y() * kShiftScale))};
}

// Height in pixels of one line of text (ascent + descent).
int text_height() {
  int baseline = 0;
  const cv::Size s = cv::getTextSize("Ag", kFont, kFontScale, 1, &baseline);
  return s.height + baseline;
}

// Width in pixels of a line of text.
int text_width(const std::string& text) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, kFontScale, 1, &baseline).width;
}

// Draws text with its top-left corner at (x, y).
void put_text(cv::Mat& canvas, const std::string& text, int x, int y, const cv::Scalar& colour = kBlack) {
  int baseline = 0;
  const cv::Size s = cv::getTextSize(text, kFont, kFontScale, 1, &baseline);
  cv::putText(canvas, text, {x, y + s.height}, kFont, kFontScale, colour, 1, cv::LINE_AA);
}

// Writes a BGR image as PNG through a temporary file; errors name the final path.
void write_png(const cv::Mat& bgr, const std::string& png_path) {
  write_via_temporary(png_path, [&](const std::string& tmp) {
    bool ok = false;
    try {
      ok = write_raster(tmp, bgr);
    } catch (const cv::Exception& e) {
      throw OutputError(png_path, std::string("OpenCV: ") + e.what());
    }
    if (!ok) throw OutputError(png_path, "OpenCV cannot write the figure (is the folder there and writable?)");
  });
}

// Grey window: the finite min..max of the values, mapped to 0..255.
struct GreyWindow {
  double lo = 0.0, hi = 0.0;
  uint8_t map(float v) const {  // NaN -> black; a flat image -> mid grey
    if (!std::isfinite(v)) return 0;
    if (hi <= lo) return 128;
    return static_cast<uint8_t>(std::clamp(std::lround(255.0 * (v - lo) / (hi - lo)), 0L, 255L));
  }
};

// The window of a set of voxel values (NaN and infinities ignored).
GreyWindow grey_window(const std::vector<float>& values) {
  GreyWindow w{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (float v : values)
    if (std::isfinite(v)) {
      w.lo = std::min<double>(w.lo, v);
      w.hi = std::max<double>(w.hi, v);
    }
  if (w.lo > w.hi) w.lo = w.hi = 0.0;
  return w;
}

// Pixels on screen for an axis of `voxels` voxels of `spacing` when a voxel of the finest
// spacing gets `factor` pixels: the others are scaled by their spacing (physical aspect).
int axis_pixels(int voxels, double spacing, double finest_spacing, int factor) {
  return std::max(1, static_cast<int>(std::lround(voxels * factor * spacing / finest_spacing)));
}

// Integer upscaling factor of the finest axis so that the longest physical side has at least
// kMinLongSidePx pixels. `extent_in_finest_voxels` is the longest side / finest spacing.
int upscale_factor(double extent_in_finest_voxels) {
  return std::max(1, static_cast<int>(std::ceil(kMinLongSidePx / extent_in_finest_voxels - 1e-9)));
}

// A 2D slice shown on screen: grey values (u fastest), its physical frame and its pixel size.
struct Panel {
  int nu = 0, nv = 0;                 // voxels along the horizontal (u) and vertical (v) axes
  std::vector<uint8_t> grey;          // nu * nv, u fastest
  Eigen::Vector2d origin, spacing;    // physical position of voxel (0, 0) and spacing along u, v
  int width_px = 0, height_px = 0;    // on screen
  std::string label;                  // drawn above the panel ("" = none)
  bool v_up = false;                  // the v axis runs upwards (z up in coronal and sagittal views)

  // Physical (u, v) to pixel coordinates: voxel i covers pixels [i, i + 1) * (pixels / voxels).
  Eigen::Vector2d to_pixel(const Eigen::Vector2d& x) const {
    Eigen::Vector2d c = (x - origin).cwiseQuotient(spacing);
    if (v_up) c.y() = nv - 1 - c.y();
    return {(c.x() + 0.5) * width_px / nu - 0.5, (c.y() + 0.5) * height_px / nv - 0.5};
  }

  // Draws the grey values, nearest neighbour, into `target` (width_px x height_px, BGR).
  void render(cv::Mat& target) const {
    for (int y = 0; y < height_px; ++y) {
      const int row_v = std::min(nv - 1, static_cast<int>((y + 0.5) * nv / height_px));
      const int v = v_up ? nv - 1 - row_v : row_v;
      auto* row = target.ptr<cv::Vec3b>(y);
      for (int x = 0; x < width_px; ++x) {
        const int u = std::min(nu - 1, static_cast<int>((x + 0.5) * nu / width_px));
        const uint8_t g = grey[static_cast<size_t>(v) * nu + u];
        row[x] = cv::Vec3b(g, g, g);
      }
    }
  }
};

// Draws segments given in physical (u, v) coordinates of a panel.
void draw_segments(cv::Mat& roi, const Panel& panel, const std::vector<std::array<Eigen::Vector2d, 2>>& segs,
                   const Rgb& rgb) {
  for (const auto& s : segs)
    cv::line(roi, fixed_point(panel.to_pixel(s[0])), fixed_point(panel.to_pixel(s[1])), to_bgr(rgb),
             kLineWidthPx, cv::LINE_AA, kShiftBits);
}

// Draws a feature point: a filled dot with a thin dark rim so it reads on any background.
void draw_dot(cv::Mat& roi, const Panel& panel, const Eigen::Vector2d& x, const Rgb& rgb) {
  const cv::Point c = fixed_point(panel.to_pixel(x));
  cv::circle(roi, c, static_cast<int>(kDotRadiusPx * kShiftScale), to_bgr(rgb), cv::FILLED, cv::LINE_AA, kShiftBits);
  cv::circle(roi, c, static_cast<int>(kDotRadiusPx * kShiftScale), cv::Scalar(40, 40, 40), 1, cv::LINE_AA, kShiftBits);
}

// A legend entry: a line colour and its label.
using LegendEntry = std::pair<Rgb, std::string>;

// The legend entries of the labelled layers: masks first (drawn first), then shapes.
template <int D>
std::vector<LegendEntry> legend_entries(const std::vector<ShapeLayer<D>>& layers, const std::vector<MaskLayer<D>>& masks) {
  std::vector<LegendEntry> entries;
  for (const auto& m : masks)
    if (!m.label.empty()) entries.emplace_back(m.rgb, m.label);
  for (const auto& l : layers)
    if (!l.label.empty()) entries.emplace_back(l.rgb, l.label);
  return entries;
}

// The legend: for each entry a short line in its colour followed by the label, in rows that wrap
// within `width` pixels. Returns the height it needs (0 when there is no entry); draws only when
// canvas is given.
int legend(const std::vector<LegendEntry>& entries, cv::Mat* canvas, int top, int width) {
  if (entries.empty()) return 0;
  const int row_h = text_height() + kMarginPx / 2;
  int x = kMarginPx, y = top;
  for (const auto& [rgb, label] : entries) {
    const int w = 36 + text_width(label);
    if (x > kMarginPx && x + w > width - kMarginPx) {  // wrap to the next row
      x = kMarginPx;
      y += row_h;
    }
    if (canvas) {
      const int mid = y + text_height() / 2;
      cv::line(*canvas, {x, mid}, {x + 28, mid}, to_bgr(rgb), kLineWidthPx + 1, cv::LINE_AA);
      put_text(*canvas, label, x + 36, y);
    }
    x += w + 24;
  }
  return y - top + text_height() + kMarginPx;
}

// The outline of the mask's inside on a panel: the mask sampled at the panel's voxel centres
// (u, v in the panel's frame; `at(u, v)` gives the physical point of voxel (u, v)) and traced by
// marching squares (meshing/surface_extraction.h) on the panel's grid, padded by one voxel.
template <int D, class At>
std::vector<std::array<Eigen::Vector2d, 2>> mask_outline(const BinaryMask<D>& mask, const Panel& panel, At&& at) {
  LabelMask<2> m;
  m.grid.size = {panel.nu + 2, panel.nv + 2};
  m.grid.spacing = panel.spacing;
  m.grid.origin = panel.origin - panel.spacing;
  m.inside.assign(size_t(m.grid.num_voxels()), 0);
  const Grid<D>& g = mask.grid();
  bool any = false;
  for (int v = 0; v < panel.nv; ++v)
    for (int u = 0; u < panel.nu; ++u) {
      const Point<D> c = g.to_continuous_index(at(u, v));
      GridIndex<D> idx;
      bool in_grid = true;
      for (int a = 0; a < D; ++a) {
        const double r = std::round(c[a]);
        in_grid &= r >= 0 && r < g.size[a];
        idx[a] = in_grid ? int(r) : 0;
      }
      if (in_grid && mask.at(idx)) {
        m.inside[size_t(v + 1) * (panel.nu + 2) + (u + 1)] = 1;
        any = true;
      }
    }
  std::vector<std::array<Eigen::Vector2d, 2>> segs;
  if (!any) return segs;
  for (const PointList<2>& loop : marching_squares(m))
    for (size_t i = 0; i < loop.size(); ++i) segs.push_back({loop[i], loop[(i + 1) % loop.size()]});
  return segs;
}

// Lays panels out side by side on a white canvas with a title band above and a legend below;
// returns the canvas and, in `rois`, where each panel went.
cv::Mat compose(const std::vector<Panel>& panels, const std::string& title, const std::vector<LegendEntry>& layers,
                std::vector<cv::Rect>& rois) {
  const bool labels = std::any_of(panels.begin(), panels.end(), [](const Panel& p) { return !p.label.empty(); });
  const bool framed = panels.size() > 1 || !title.empty() || !layers.empty();
  const int margin = framed ? kMarginPx : 0;
  const int title_h = title.empty() ? 0 : text_height() + kMarginPx;
  const int label_h = labels ? text_height() + kMarginPx / 2 : 0;
  // A panel's slot is as wide as the panel or its label, whichever is wider.
  auto slot = [](const Panel& p) { return std::max(p.width_px, p.label.empty() ? 0 : text_width(p.label)); };
  int width = margin, panel_h = 0;
  for (const auto& p : panels) {
    width += slot(p) + margin;
    panel_h = std::max(panel_h, p.height_px);
  }
  const int panel_top = margin + title_h + label_h;
  width = std::max(width, title.empty() ? 0 : text_width(title) + 2 * kMarginPx);
  const int legend_h = legend(layers, nullptr, 0, width);
  const int height = panel_top + panel_h + margin + legend_h;
  cv::Mat canvas(height, width, CV_8UC3, kWhite);
  if (!title.empty()) put_text(canvas, title, margin, margin);
  int x = margin;
  rois.clear();
  for (const auto& p : panels) {
    rois.emplace_back(x, panel_top, p.width_px, p.height_px);
    cv::Mat roi = canvas(rois.back());
    p.render(roi);
    if (!p.label.empty()) put_text(canvas, p.label, x, margin + title_h);
    x += slot(p) + margin;
  }
  legend(layers, &canvas, panel_top + panel_h + margin, width);
  return canvas;
}

// Checks that a layer's connectivity matches its points (a programmer error otherwise).
template <int D>
void check_layer(const ShapeLayer<D>& layer) {
  DSNAKE_ASSERT(static_cast<int>(layer.points.size()) == layer.connectivity.num_vertices(),
                "figure layer: " + std::to_string(layer.points.size()) + " points but connectivity has " +
                    std::to_string(layer.connectivity.num_vertices()) + " vertices");
  for (int v : layer.marked_vertices)
    DSNAKE_ASSERT(v >= 0 && v < static_cast<int>(layer.points.size()),
                  "figure layer: marked vertex " + std::to_string(v) + " out of range");
}

// Cross-section of a triangle mesh with the plane x[axis] = level, as segments in 3D.
// A vertex exactly on the plane counts as lying above it (a symbolic perturbation), so that
// every crossing edge has vertices strictly on both sides: each triangle gives at most one
// segment, an edge lying in the plane is drawn once, and a plane touching a vertex adds nothing.
std::vector<std::array<Point<3>, 2>> cross_section(const PointList<3>& p, const std::vector<Triangle>& tris,
                                                   int axis, double level) {
  std::vector<std::array<Point<3>, 2>> segs;
  for (const auto& t : tris) {
    std::array<double, 3> d;
    std::array<bool, 3> above;
    for (int k = 0; k < 3; ++k) {
      d[k] = p[t[k]][axis] - level;
      above[k] = d[k] >= 0.0;
    }
    if (above[0] == above[1] && above[1] == above[2]) continue;
    std::array<Point<3>, 2> seg;
    int n = 0;
    for (int k = 0; k < 3 && n < 2; ++k) {
      const int a = k, b = (k + 1) % 3;
      if (above[a] == above[b]) continue;
      const double s = d[a] / (d[a] - d[b]);  // d[a] - d[b] != 0: strictly opposite sides or one is 0
      seg[n++] = p[t[a]] + s * (p[t[b]] - p[t[a]]);
    }
    if ((seg[0] - seg[1]).squaredNorm() > 0.0) segs.push_back(seg);
  }
  return segs;
}

// Tick label text: 3 significant digits.
std::string tick_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

}  // namespace

void write_overlay_figure(const Image<2>& image, const std::vector<ShapeLayer2>& layers,
                          const std::string& png_path, const std::string& title, const std::vector<MaskLayer<2>>& masks,
                          const std::vector<std::array<Point<2>, 2>>& links) {
  DSNAKE_ASSERT(!image.empty(), "write_overlay_figure: empty image for " + png_path);
  for (const auto& l : layers) check_layer(l);
  const GreyWindow window = grey_window(image.data());
  Panel panel;
  panel.nu = image.size()[0];
  panel.nv = image.size()[1];
  panel.origin = image.origin();
  panel.spacing = image.spacing();
  const double finest = image.spacing().minCoeff();
  const int factor = upscale_factor(std::max(panel.nu * panel.spacing[0], panel.nv * panel.spacing[1]) / finest);
  panel.width_px = axis_pixels(panel.nu, panel.spacing[0], finest, factor);
  panel.height_px = axis_pixels(panel.nv, panel.spacing[1], finest, factor);
  panel.grey.resize(image.data().size());
  std::transform(image.data().begin(), image.data().end(), panel.grey.begin(),
                 [&](float v) { return window.map(v); });
  if (!title.empty()) {  // a framed figure (as runs write) says where it is, in mm
    const Point<2> end = image.origin() + (image.size().cast<double>() - Point<2>::Ones()).cwiseProduct(image.spacing());
    panel.label = "x " + tick_text(image.origin()[0]) + " to " + tick_text(end[0]) + " mm right (L), y " +
                  tick_text(image.origin()[1]) + " to " + tick_text(end[1]) + " mm down (P)";
  }

  std::vector<cv::Rect> rois;
  std::vector<LegendEntry> entries = legend_entries(layers, masks);
  if (!links.empty()) entries.insert(entries.begin() + static_cast<long>(masks.size()), {kLinkGreen, "correspondence"});
  cv::Mat canvas = compose(std::vector<Panel>{panel}, title, entries, rois);
  cv::Mat roi = canvas(rois[0]);
  for (const auto& m : masks)
    draw_segments(roi, panel,
                  mask_outline(m.mask, panel, [&](int u, int v) { return Point<2>(image.grid().to_physical({u, v})); }),
                  m.rgb);
  for (const auto& l : links)
    cv::line(roi, fixed_point(panel.to_pixel(l[0])), fixed_point(panel.to_pixel(l[1])), to_bgr(kLinkGreen), 1,
             cv::LINE_AA, kShiftBits);
  for (const auto& l : layers) {
    if (l.connectivity.is_polygon()) {
      // One closed polyline joins the corners cleanly (separate lines would leave notches).
      std::vector<cv::Point> pts;
      for (const auto& x : l.points) pts.push_back(fixed_point(panel.to_pixel(x)));
      cv::polylines(roi, pts, true, to_bgr(l.rgb), kLineWidthPx, cv::LINE_AA, kShiftBits);
    } else {
      std::vector<std::array<Eigen::Vector2d, 2>> segs;
      for (const auto& e : l.connectivity.edges()) segs.push_back({l.points[e[0]], l.points[e[1]]});
      draw_segments(roi, panel, segs, l.rgb);
    }
  }
  for (const auto& l : layers)
    for (int v : l.marked_vertices) draw_dot(roi, panel, l.points[v], l.marker_rgb);
  write_png(canvas, png_path);
}

namespace {

// (normal axis, horizontal axis, vertical axis, name, v upwards, orientation) of axial, coronal
// and sagittal views in the radiological convention of LPS world coordinates (image.h): axial
// with the patient's left (+x) on the right and posterior (+y) down, coronal and sagittal with
// superior (+z) up. The frame of an oblique scan is shown in its grid's planes (slice_label).
struct SliceView { int normal, u, v; const char* name; bool v_up; const char* orientation; };
constexpr std::array<SliceView, 3> kSliceViews{{{2, 0, 1, "axial", false, "x right = L, y down = P"},
                                        {1, 0, 2, "coronal", true, "x right = L, z up = S"},
                                        {0, 1, 2, "sagittal", true, "y right = P, z up = S"}}};

// The panel of one view: the slice's voxels through the grey window, at the figure's scale.
Panel slice_panel(const Image<3>& volume, const GreyWindow& window, const GridIndex<3>& slice, const SliceView& view,
                  double finest, int factor) {
  const Grid<3>& grid = volume.grid();
  Panel p;
  p.nu = grid.size[view.u];
  p.nv = grid.size[view.v];
  p.origin = {grid.origin[view.u], grid.origin[view.v]};
  p.spacing = {grid.spacing[view.u], grid.spacing[view.v]};
  p.width_px = axis_pixels(p.nu, p.spacing[0], finest, factor);
  p.height_px = axis_pixels(p.nv, p.spacing[1], finest, factor);
  p.grey.resize(static_cast<size_t>(p.nu) * p.nv);
  GridIndex<3> idx = slice;
  for (int j = 0; j < p.nv; ++j)
    for (int i = 0; i < p.nu; ++i) {
      idx[view.u] = i;
      idx[view.v] = j;
      p.grey[static_cast<size_t>(j) * p.nu + i] = window.map(volume.at(idx));
    }
  p.v_up = view.v_up;
  p.label = slice_label(grid, slice, view.normal);
  return p;
}

}  // namespace

std::string slice_label(const Grid<3>& grid, const GridIndex<3>& slice, int normal) {
  static const char* kAxis = "xyz";
  const SliceView& view = kSliceViews[2 - normal];
  if (!grid.axis_aligned()) {
    const Point<3> w = grid.to_world(grid.to_physical(slice));
    return std::string("grid ") + kAxis[view.normal] + " plane through (" + tick_text(w[0]) + ", " + tick_text(w[1]) +
           ", " + tick_text(w[2]) + ") mm";
  }
  const double level = grid.origin[view.normal] + slice[view.normal] * grid.spacing[view.normal];
  return std::string(view.name) + "  " + kAxis[view.normal] + " = " + tick_text(level) + " mm  (" + view.orientation + ")";
}

void write_slice_figure(const Image<3>& volume, const std::vector<ShapeLayer3>& layers, const Point<3>& centre,
                        const std::string& png_path, const std::string& title, const std::vector<MaskLayer<3>>& masks) {
  DSNAKE_ASSERT(!volume.empty(), "write_slice_figure: empty volume for " + png_path);
  for (const auto& l : layers) {
    check_layer(l);
    DSNAKE_ASSERT(!l.connectivity.is_polygon(), "write_slice_figure: a 3D layer needs triangles");
  }
  const Grid<3>& grid = volume.grid();
  const GreyWindow window = grey_window(volume.data());
  const double finest = grid.spacing.minCoeff();
  double longest = 0.0;
  for (int a = 0; a < 3; ++a) longest = std::max(longest, grid.size[a] * grid.spacing[a]);
  const int factor = upscale_factor(longest / finest);

  // Slice voxel nearest to the centre along each axis.
  const Point<3> c = grid.to_continuous_index(centre);
  GridIndex<3> slice;
  for (int a = 0; a < 3; ++a) slice[a] = std::clamp(static_cast<int>(std::lround(c[a])), 0, grid.size[a] - 1);

  const auto& views = kSliceViews;
  std::vector<Panel> panels;
  for (const auto& view : views) panels.push_back(slice_panel(volume, window, slice, view, finest, factor));

  std::vector<cv::Rect> rois;
  cv::Mat canvas = compose(panels, title, legend_entries(layers, masks), rois);
  for (size_t k = 0; k < views.size(); ++k) {
    const SliceView& view = views[k];
    const Panel& panel = panels[k];
    cv::Mat roi = canvas(rois[k]);
    const double level = grid.origin[view.normal] + slice[view.normal] * grid.spacing[view.normal];
    auto project = [&](const Point<3>& x) { return Eigen::Vector2d(x[view.u], x[view.v]); };
    for (const auto& m : masks) {
      auto at = [&](int u, int v) {
        GridIndex<3> idx = slice;
        idx[view.u] = u;
        idx[view.v] = v;
        return grid.to_physical(idx);
      };
      draw_segments(roi, panel, mask_outline(m.mask, panel, at), m.rgb);
    }
    for (const auto& l : layers) {
      std::vector<std::array<Eigen::Vector2d, 2>> segs;
      for (const auto& s : cross_section(l.points, l.connectivity.triangles(), view.normal, level))
        segs.push_back({project(s[0]), project(s[1])});
      draw_segments(roi, panel, segs, l.rgb);
    }
    const double half_voxel = 0.5 * grid.spacing[view.normal];
    for (const auto& l : layers)
      for (int v : l.marked_vertices)
        if (std::abs(l.points[v][view.normal] - level) <= half_voxel)
          draw_dot(roi, panel, project(l.points[v]), l.marker_rgb);
  }
  write_png(canvas, png_path);
}

}  // namespace dsnake
