// `dsnake field`; see field_command.h.
#include "experiments/cli/field_command.h"

#include "fields/registry.h"
#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/raster_codecs.h"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace dsnake {

namespace {

constexpr int kMinLongSidePx = 512;  // as experiments/output/figures.cpp
constexpr int kArrowsAlongLongSide = 32;

// The field's JSON object: {"type": ..., params..., "cache": ...}.
nlohmann::json field_spec(const FieldCommandOptions& o) {
  nlohmann::json spec = {{"type", o.type}};
  for (const std::string& p : o.params) {
    const size_t eq = p.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError("", "--param " + p, "expected key=value (e.g. --param mu=0.1)");
    const std::string key = p.substr(0, eq), value = p.substr(eq + 1);
    const nlohmann::json parsed = nlohmann::json::parse(value, nullptr, false);
    spec[key] = parsed.is_discarded() ? nlohmann::json(value) : parsed;
  }
  if (!o.cache.empty()) spec["cache"] = o.cache;
  return spec;
}

std::string png_path(const FieldCommandOptions& o) {
  if (!o.png.empty()) return o.png;
  std::string base = o.out;
  for (const char* ext : {".nii.gz", ".mha", ".mhd", ".nii", ".nrrd", ".nhdr", ".inr.gz", ".inr"})
    if (base.size() > std::string(ext).size() && base.ends_with(ext)) {
      base.resize(base.size() - std::string(ext).size());
      break;
    }
  return base + ".png";
}

// The colour of a relative magnitude t in [0, 1]: OpenCV's viridis map (perceptually uniform,
// readable in grey), as BGR.
cv::Vec3b magnitude_colour(double t) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1), out;
    for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = uint8_t(i);
    cv::applyColorMap(ramp, out, cv::COLORMAP_VIRIDIS);
    return out;
  }();
  return lut.at<cv::Vec3b>(0, std::clamp(int(std::lround(255.0 * t)), 0, 255));
}

// The band under the image that keeps the magnitude: a colour bar from 0 to |F|max with both
// values written at its ends, and what the arrows show.
void draw_magnitude_legend(cv::Mat& canvas, int top, double f_max) {
  const int w = canvas.cols, bar_x0 = 12, bar_x1 = std::max(bar_x0 + 2, w - 12), bar_y = top + 8, bar_h = 14;
  for (int x = bar_x0; x < bar_x1; ++x)
    for (int y = bar_y; y < bar_y + bar_h; ++y)
      canvas.at<cv::Vec3b>(y, x) = magnitude_colour(double(x - bar_x0) / (bar_x1 - bar_x0 - 1));
  char high[64];
  std::snprintf(high, sizeof high, "%.4g", f_max);
  const auto font = cv::FONT_HERSHEY_SIMPLEX;
  const cv::Scalar ink(20, 20, 20);
  int base = 0;
  const cv::Size hs = cv::getTextSize(high, font, 0.45, 1, &base);
  cv::putText(canvas, "0", {bar_x0, bar_y + bar_h + 16}, font, 0.45, ink, 1, cv::LINE_AA);
  cv::putText(canvas, high, {bar_x1 - hs.width, bar_y + bar_h + 16}, font, 0.45, ink, 1, cv::LINE_AA);
  cv::putText(canvas, "|F|: arrow colour and length (the longest = max); the field's units", {bar_x0, bar_y + bar_h + 36},
              font, 0.45, ink, 1, cv::LINE_AA);
}

// The image (grey window min..max, nearest neighbour, physical aspect, y downwards) with the
// field's arrows on a regular grid of voxels, arrow length proportional to |F| (the longest one
// step pixels) and coloured by |F| / |F|max; below it, kLegendPx rows of legend: the colour bar
// from 0 to |F|max, so that the figure keeps the field's magnitude.
void write_field_png(const Image<2>& image, const VectorField<2>& field, const std::string& path) {
  const Grid<2>& g = image.grid();
  const double finest = std::min(g.spacing[0], g.spacing[1]);
  const double long_side = std::max(g.size[0] * g.spacing[0], g.size[1] * g.spacing[1]) / finest;
  const int factor = std::max(1, int(std::ceil(kMinLongSidePx / long_side - 1e-9)));
  const double px[2] = {factor * g.spacing[0] / finest, factor * g.spacing[1] / finest};  // pixels per voxel
  const int w = std::max(1, int(std::lround(g.size[0] * px[0]))), h = std::max(1, int(std::lround(g.size[1] * px[1])));
  float lo = image[0], hi = image[0];
  for (float v : image.data())
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  cv::Mat canvas(h + kFieldLegendPx, w, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int i = std::min(g.size[0] - 1, int(x / px[0])), j = std::min(g.size[1] - 1, int(y / px[1]));
      const float v = image.at(GridIndex<2>(i, j));
      const uint8_t grey = hi > lo ? uint8_t(std::clamp(std::lround(255.0 * (v - lo) / (hi - lo)), 0L, 255L)) : 128;
      canvas.at<cv::Vec3b>(y, x) = cv::Vec3b(grey, grey, grey);
    }
  const int step = std::max(1, std::max(g.size[0], g.size[1]) / kArrowsAlongLongSide);
  double f_max = 0;
  for (int64_t l = 0; l < field.num_voxels(); ++l) f_max = std::max(f_max, field[l].norm());
  if (f_max > 0) {
    const double step_px = step * std::min(px[0], px[1]);
    cv::Mat arrows = canvas(cv::Rect(0, 0, w, h));
    for (int j = step / 2; j < g.size[1]; j += step)
      for (int i = step / 2; i < g.size[0]; i += step) {
        const Point<2> f = field[g.linear(GridIndex<2>(i, j))];
        if (f.norm() < 1e-3 * f_max) continue;
        // Physical direction -> pixels: x right, y down (row = y index).
        const Eigen::Vector2d dir(f.x() / g.spacing[0] * px[0], f.y() / g.spacing[1] * px[1]);
        const Eigen::Vector2d d = dir.normalized() * (f.norm() / f_max) * step_px;
        const cv::Point2d from((i + 0.5) * px[0], (j + 0.5) * px[1]);
        const cv::Vec3b c = magnitude_colour(f.norm() / f_max);
        cv::arrowedLine(arrows, from, from + cv::Point2d(d.x(), d.y()), cv::Scalar(c[0], c[1], c[2]), 1, cv::LINE_AA, 0, 0.3);
      }
  }
  draw_magnitude_legend(canvas, h, f_max);
  write_via_temporary(path, [&](const std::string& tmp) {
    if (!write_raster(tmp, canvas)) throw OutputError(path, "OpenCV cannot write the figure");
  });
}

template <int D>
int run(const FieldCommandOptions& o) {
  ImageLayout layout;
  Image<D> image = read_image<D>(o.image, o.read, &layout);
  const nlohmann::json spec = field_spec(o);
  JsonReader reader(spec, "", "field");
  auto field = build_field<D>(read_field_spec<D>(reader));
  const auto t0 = std::chrono::steady_clock::now();
  const bool figure = D == 2 && !o.no_png;
  if (figure) {
    field->compute(image);
  } else {
    compute_releasing(*field, std::move(image));  // the image is not needed again
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_vector_field(field->vectors(), o.out, layout);  // on the image file's grid
  std::printf("%s: %s field of %s (%.3f s) -> %s\n", o.image.c_str(), field->type().c_str(),
              D == 2 ? "an image" : "a volume", seconds, o.out.c_str());
  if constexpr (D == 2) {
    if (!o.no_png) {
      const std::string png = png_path(o);
      write_field_png(image, field->vectors(), png);
      std::printf("figure -> %s\n", png.c_str());
    }
  }
  return 0;
}

}  // namespace

int run_field_command(const FieldCommandOptions& options) {
  if (options.image.empty()) throw InputError("", "--image", "is required");
  if (options.out.empty()) throw InputError("", "--out", "is required");
  return image_file_dimension(options.image) == 2 ? run<2>(options) : run<3>(options);
}

}  // namespace dsnake
