// OpenCV's image codecs on first use; see raster_codecs.h.
#include "framework/io/raster_codecs.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <dlfcn.h>
#include <opencv2/imgcodecs.hpp>  // declarations only: checks the signatures below, links nothing

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

}  // namespace

cv::Mat read_raster(const std::string& path, int flags) {
  const Codecs& c = codecs();
  if (!c.read) throw InputError(path, "", c.error);
  return c.read(path, flags);
}

bool write_raster(const std::string& path, const cv::Mat& image) {
  const Codecs& c = codecs();
  if (!c.write) throw OutputError(path, c.error);
  return c.write(path, image, std::vector<int>());
}

}  // namespace dsnake
