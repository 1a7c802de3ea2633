// Vector field convolution (Li & Acton, "Active contour external force using vector field
// convolution for image segmentation", IEEE TIP 2007), one of the diffused edge forces D-Snake
// compares against (Levi & Gotsman, §2): the edge map f (fields/edge_map.h) convolved with the
// vector kernel k(x) = m(|x|) n(x), n(x) = -x / |x| (pointing at the kernel's centre), |x| <= R:
//     F(x) = sum_y f(y) k(x - y) dV,
// so each edge voxel pulls towards itself with the magnitude m of its distance. m is either
// (r + eps)^-gamma ("power") or exp(-r^2 / zeta^2) ("gaussian"). Physical units throughout
// (R, eps, zeta in mm; dV the voxel volume), so anisotropic voxels give the same field.
// Convolved with single-precision FFTW in 2D and 3D (zero padding: a linear, not circular,
// convolution; float spectra, relative error ~1e-6 of the largest vector); the
// plans and the kernel spectra are made once and reused while the grid stays the same.
#pragma once

#include "fields/edge_map.h"
#include "framework/core/external_field.h"

#include <memory>
#include <string>

namespace dsnake {

// The kernel's magnitude m(r): kPower ("power"): (r + eps)^-gamma; kGaussian ("gaussian"):
// exp(-r^2 / zeta^2).
enum class VfcKernel { kPower, kGaussian };
template <>
struct EnumNames<VfcKernel> {
  static constexpr std::array<std::pair<VfcKernel, const char*>, 2> table{
      {{VfcKernel::kPower, "power"}, {VfcKernel::kGaussian, "gaussian"}}};
};

struct VfcFieldOptions {
  EdgeMapOptions edge;                  // JSON: "sigma", "normalize"
  double radius = 16.0;                 // kernel radius R, physical units, <= the image extent
  VfcKernel kernel = VfcKernel::kPower;
  double gamma = 2.0;                   // power kernel exponent
  double epsilon = 1e-8;                // power kernel regulariser (mm)
  double zeta = 0.0;                    // Gaussian kernel width (mm); 0: R / 2

  template <class V>
  void visit(V& v) {
    edge.visit(v);
    v(radius, Key{"radius", "mm", "kernel radius R (at most the image's largest extent, checked at compute)",
                  Range::greater_than(0)});
    v(kernel, Key{"kernel", "", "kernel magnitude m(r): power (r + epsilon)^-gamma or gaussian exp(-r^2 / zeta^2)"});
    v(gamma, Key{"gamma", "1", "power kernel: exponent", Range::greater_than(0)});
    v(epsilon, Key{"epsilon", "mm", "power kernel: regulariser of r", Range::at_least(0)});
    v(zeta, Key{"zeta", "mm", "gaussian kernel: width (0: radius / 2)", Range::at_least(0)});
  }
};

// Wall-clock seconds of the last compute(), for benchmarks.
struct VfcTimings {
  double plan_s = 0, kernel_s = 0, convolve_s = 0;
};

template <int D>
class VfcField final : public ExternalField<D>, public CacheableField<D> {
 public:
  using Options = VfcFieldOptions;
  static constexpr const char* kType = "vfc";
  void check_grid(const Grid<D>& grid) const override;
  static constexpr const char* kSummary = "vector field convolution, Li & Acton 2007 (compared in D-Snake §2)";

  explicit VfcField(const VfcFieldOptions& options = {});
  ~VfcField() override;

  std::string type() const override { return kType; }
  const VfcFieldOptions& options() const { return options_; }

  // Edge map, then the FFT convolution. Throws InputError naming "field.radius" if R is larger
  // than the image (its largest physical extent).
  void compute(const Image<D>& image) override;
  // F at x, linearly interpolated (the normal is not used).
  Point<D> force(const Point<D>& x, const Point<D>& normal) const override;
  const VectorField<D>& vectors() const override { return vectors_; }
  const VfcTimings& timings() const { return timings_; }

  // The kernel k at offset d (physical units), for tests and direct convolution.
  Point<D> kernel(const Point<D>& d) const;

  std::string save_state() const override;
  bool load_state(const Grid<D>& grid, const std::string& bytes) override;

 private:
  struct Fft;  // FFTW plans, buffers and kernel spectra (vfc.cpp)
  VfcFieldOptions options_;
  std::unique_ptr<Fft> fft_;
  VfcTimings timings_;
  VectorField<D> vectors_;
};

}  // namespace dsnake
