// OpenCV's image codecs on first use; see raster_codecs.h.
#include "framework/io/raster_codecs.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/io/image_io_detail.h"

#include <dlfcn.h>
#include <png.h>
#include <zlib.h>
#include <opencv2/imgcodecs.hpp>  // declarations only: checks the signatures below, links nothing

#include <csetjmp>
#include <cstdio>
#include <memory>
#include <type_traits>
#include <vector>

namespace dsnake {

namespace {

using ReadFn = cv::Mat (*)(const cv::String&, int);
using WriteFn = bool (*)(const cv::String&, cv::InputArray, const std::vector<int>&);
// The pointer types are exactly OpenCV's declarations (a different signature fails to compile;
// decltype does not odr-use the functions, so nothing is linked).
static_assert(std::is_same_v<decltype(&cv::imread), ReadFn>);
static_assert(std::is_same_v<decltype(&cv::imwrite), WriteFn>);

// The library (its soname, from CMake) and the two functions, or why they could not be found.
struct Codecs {
  ReadFn read = nullptr;
  WriteFn write = nullptr;
  std::string error;
};

const Codecs& codecs() {
  static const Codecs loaded = [] {
    Codecs c;
    void* lib = dlopen(DSNAKE_OPENCV_IMGCODECS, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
      const char* e = dlerror();
      c.error = std::string("cannot load OpenCV's image codecs (") + (e ? e : DSNAKE_OPENCV_IMGCODECS) + ")";
      return c;
    }
    // The GCC (C++11 ABI) names of cv::imread(const String&, int) and
    // cv::imwrite(const String&, InputArray, const std::vector<int>&).
    c.read = reinterpret_cast<ReadFn>(dlsym(lib, "_ZN2cv6imreadERKNSt7__cxx1112basic_stringIcSt11char_traitsIcESaIcEEEi"));
    c.write = reinterpret_cast<WriteFn>(dlsym(
        lib, "_ZN2cv7imwriteERKNSt7__cxx1112basic_stringIcSt11char_traitsIcESaIcEEERKNS_11_InputArrayERKSt6vectorIiSaIiEE"));
    if (!c.read || !c.write) c.error = std::string("cannot find cv::imread / cv::imwrite in ") + DSNAKE_OPENCV_IMGCODECS;
    return c;
  }();
  return loaded;
}

// libpng reports errors by longjmp: the message is kept for the caller's false.
void png_error_handler(png_structp png, png_const_charp) { std::longjmp(png_jmpbuf(png), 1); }
void png_warning_handler(png_structp, png_const_charp) {}

// An 8-bit grey or BGR, or 16-bit grey, image as PNG with libpng, as OpenCV's encoder writes it
// by default (the "sub" filter, zlib level 1, run-length strategy; BGR stored as RGB, 16-bit
// big-endian): the same pixels as cv::imwrite. libpng is small and linked; cv::imwrite would need
// OpenCV's image codecs, whose 140 libraries take about 90 ms to load (every run
// writes its figures).
// False if the file cannot be opened or written.
bool write_png_with_libpng(const std::string& path, const cv::Mat& image) {
  const int channels = image.channels();
  const bool wide = image.depth() == CV_16U;
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) return false;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, png_error_handler, png_warning_handler);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  // Nothing below owns memory that a longjmp would leak: the rows point into `image`.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file.get());
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_compression_level(png, Z_BEST_SPEED);
  png_set_compression_strategy(png, Z_RLE);
  png_set_IHDR(png, info, png_uint_32(image.cols), png_uint_32(image.rows), wide ? 16 : 8,
               channels == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  png_write_info(png, info);
  if (channels == 3) png_set_bgr(png);
  if (wide) png_set_swap(png);  // the host's little-endian samples, big-endian in the file
  for (int y = 0; y < image.rows; ++y) png_write_row(png, image.ptr<png_byte>(y));
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return std::fflush(file.get()) == 0 && !std::ferror(file.get());
}

}  // namespace

cv::Mat read_raster(const std::string& path, int flags) {
  const Codecs& c = codecs();
  if (!c.read) throw InputError(path, "", c.error);
  return c.read(path, flags);
}

bool write_raster(const std::string& path, const cv::Mat& image) {
  const int type = image.type();
  if (detail::extension_of(path) == ".png" && !image.empty() && (type == CV_8UC1 || type == CV_8UC3 || type == CV_16UC1))
    return write_png_with_libpng(path, image);
  const Codecs& c = codecs();
  if (!c.write) throw OutputError(path, c.error);
  return c.write(path, image, std::vector<int>());
}

}  // namespace dsnake
