// 2D raster files (PNG, JPEG, BMP, TIFF) through OpenCV's image codecs, loaded on first use.
//
// libopencv_imgcodecs pulls in about 140 shared libraries (GDAL, poppler, HDF5, ...) that cost
// every process 40 MB of resident memory and their start-up, although only 2D raster input and
// the figures need them.
// So dsnake does not link it: these two calls open it with dlopen the first time they are used
// and call OpenCV's own cv::imread / cv::imwrite (the signatures are checked against OpenCV's
// header at compile time). OpenCV's exceptions pass through unchanged.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace dsnake {

// cv::imread(path, flags) (flags: cv::IMREAD_*). Throws InputError naming `path` if the codec
// library cannot be loaded.
cv::Mat read_raster(const std::string& path, int flags);

// cv::imwrite(path, image); false if OpenCV cannot write it. Throws OutputError naming `path` if
// the codec library cannot be loaded. PNG files of 8-bit grey or BGR, or 16-bit grey, images (the
// figures, 2D results) are written with libpng instead, with OpenCV's default settings and the same
// pixels, so that writing a figure does not load the codec library.
bool write_raster(const std::string& path, const cv::Mat& image);

}  // namespace dsnake
