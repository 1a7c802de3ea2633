// Vector field convolution with FFTW; see vfc.h (Li & Acton 2007; D-Snake §2).
#include "fields/vfc.h"

#include "fields/field_state.h"
#include "framework/core/errors.h"

#include <fftw3.h>  // single precision (fftwf_*): half the memory traffic of double
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <mutex>

namespace dsnake {

namespace {

// FFTW's planner is not thread-safe; its thread support is initialised once.
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}
void init_fftw_threads() {
  static std::once_flag once;
  std::call_once(once, [] { fftwf_init_threads(); });
}

// The smallest n' >= n whose only prime factors are 2, 3, 5 and 7 (fast FFT sizes).
int fft_size(int n) {
  for (int m = std::max(n, 1);; ++m) {
    int r = m;
    for (int p : {2, 3, 5, 7})
      while (r % p == 0) r /= p;
    if (r == 1) return m;
  }
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct FftwDeleter {
  void operator()(float* p) const { fftwf_free(p); }
};
using FftwBuffer = std::unique_ptr<float, FftwDeleter>;

}  // namespace

// Padded grid N (x fastest), an in-place r2c / c2r plan pair on it, and the D kernel spectra.
template <int D>
struct VfcField<D>::Fft {
  Grid<D> grid;            // the image grid the spectra were made for
  int threads = 0;         // the plans' thread count
  std::array<int, D> n{};  // padded sizes per axis (x first)
  int64_t real_stride = 0, complex_count = 0, buffer_floats = 0;
  fftwf_plan forward = nullptr, backward = nullptr;
  FftwBuffer work, product;
  std::array<FftwBuffer, D> kernel_spectra;

  ~Fft() {
    std::lock_guard<std::mutex> lock(planner_mutex());
    if (forward) fftwf_destroy_plan(forward);
    if (backward) fftwf_destroy_plan(backward);
  }
  // Offset l of padded index (i0 = x, i1, i2) in the in-place real layout (rows padded to
  // 2 (N_x / 2 + 1) floats).
  int64_t at(const std::array<int, D>& i) const {
    int64_t off = i[D - 1];
    for (int a = D - 2; a >= 1; --a) off = off * n[a] + i[a];
    return off * real_stride + i[0];
  }
  // Padded sizes (linear, not circular, convolution), buffers and the r2c / c2r plan pair.
  void plan(const Grid<D>& image_grid, int plan_threads, const std::array<int, D>& half);
  // The D kernel spectra: k_a sampled at offsets d in [-half, half], wrapped around the padded grid.
  void make_kernel_spectra(const VfcField<D>& field, const std::array<int, D>& half);
  // F_a = IFFT(FFT(f) * FFT(k_a)) / N, cropped to the image grid into `vectors`.
  void convolve(const Grid<D>& image_grid, const float* f, VectorField<D>& vectors);
};

template <int D>
void VfcField<D>::Fft::plan(const Grid<D>& image_grid, int plan_threads, const std::array<int, D>& half) {
  grid = image_grid;
  threads = plan_threads;
  for (int a = 0; a < D; ++a) n[a] = fft_size(image_grid.size[a] + half[a]);  // linear, not circular
  real_stride = 2 * (n[0] / 2 + 1);
  int64_t rows = 1;
  for (int a = 1; a < D; ++a) rows *= n[a];
  buffer_floats = rows * real_stride;
  complex_count = buffer_floats / 2;
  work.reset(fftwf_alloc_real(buffer_floats));
  product.reset(fftwf_alloc_real(buffer_floats));
  int dims[D];
  for (int a = 0; a < D; ++a) dims[a] = n[D - 1 - a];  // FFTW: last dimension fastest
  {
    std::lock_guard<std::mutex> lock(planner_mutex());
    fftwf_plan_with_nthreads(plan_threads);
    float* w = work.get();
    forward = fftwf_plan_dft_r2c(D, dims, w, reinterpret_cast<fftwf_complex*>(w), FFTW_ESTIMATE);
    backward = fftwf_plan_dft_c2r(D, dims, reinterpret_cast<fftwf_complex*>(w), w, FFTW_ESTIMATE);
  }
  DSNAKE_ASSERT(forward && backward, "FFTW plans");
}

template <int D>
void VfcField<D>::Fft::make_kernel_spectra(const VfcField<D>& field, const std::array<int, D>& half) {
  double dv = 1;
  for (int a = 0; a < D; ++a) dv *= grid.spacing[a];
  for (int a = 0; a < D; ++a) {
    kernel_spectra[a].reset(fftwf_alloc_real(buffer_floats));
    std::fill_n(kernel_spectra[a].get(), buffer_floats, 0.0f);
  }
  int64_t count = 1;
  for (int a = 0; a < D; ++a) count *= 2 * half[a] + 1;
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < count; ++l) {
    std::array<int, D> wrapped{};
    Point<D> d;
    int64_t rest = l;
    for (int a = 0; a < D; ++a) {
      const int o = int(rest % (2 * half[a] + 1)) - half[a];
      rest /= 2 * half[a] + 1;
      d[a] = o * grid.spacing[a];
      wrapped[a] = o < 0 ? o + n[a] : o;
    }
    const Point<D> k = field.kernel(d) * dv;
    const int64_t offset = at(wrapped);
    for (int a = 0; a < D; ++a) kernel_spectra[a].get()[offset] = float(k[a]);
  }
  for (int a = 0; a < D; ++a) {
    float* k = kernel_spectra[a].get();
    fftwf_execute_dft_r2c(forward, k, reinterpret_cast<fftwf_complex*>(k));
  }
}

template <int D>
void VfcField<D>::Fft::convolve(const Grid<D>& image_grid, const float* f, VectorField<D>& vectors) {
  float* w = work.get();
  // Image rows (x runs) to padded rows and back: row r of the image is padded row pad_row(r).
  const int nx = image_grid.size[0];
  const int64_t image_rows = image_grid.num_voxels() / nx;
  auto pad_row = [&](int64_t r) {
    int64_t off = 0, mul = 1;
    for (int a = 1; a < D; ++a) {
      off += (r % image_grid.size[a]) * mul;
      r /= image_grid.size[a];
      mul *= n[a];
    }
    return off * real_stride;
  };
  std::fill_n(w, buffer_floats, 0.0f);
#pragma omp parallel for schedule(static)
  for (int64_t r = 0; r < image_rows; ++r) std::copy_n(f + r * nx, nx, w + pad_row(r));
  fftwf_execute_dft_r2c(forward, w, reinterpret_cast<fftwf_complex*>(w));
  double n_total = 1;
  for (int a = 0; a < D; ++a) n_total *= n[a];
  const float scale = float(1.0 / n_total);
  const auto* fhat = reinterpret_cast<const std::complex<float>*>(w);
  for (int a = 0; a < D; ++a) {
    const auto* khat = reinterpret_cast<const std::complex<float>*>(kernel_spectra[a].get());
    auto* out = reinterpret_cast<std::complex<float>*>(product.get());
#pragma omp parallel for schedule(static)
    for (int64_t l = 0; l < complex_count; ++l) out[l] = fhat[l] * khat[l] * scale;
    fftwf_execute_dft_c2r(backward, reinterpret_cast<fftwf_complex*>(product.get()), product.get());
    const float* real = product.get();
#pragma omp parallel for schedule(static)
    for (int64_t r = 0; r < image_rows; ++r) {
      const float* src = real + pad_row(r);
      for (int x = 0; x < nx; ++x) vectors.at(r * nx + x)[a] = float(src[x]);
    }
  }
}

template <int D>
VfcField<D>::VfcField(const VfcFieldOptions& options) : options_(checked(options, kType)) {}

template <int D>
VfcField<D>::~VfcField() = default;

template <int D>
Point<D> VfcField<D>::kernel(const Point<D>& d) const {
  const double r = d.norm();
  // (the cut at the radius has a 1e-9 relative margin: an offset on the circle r = R, e.g. 6
  // voxels of 1 mm for R = 6, stays in for a spacing a rounding error above 1 mm)
  if (r == 0.0 || r > options_.radius * (1 + 1e-9)) return Point<D>::Zero();
  double m;
  if (options_.kernel == VfcKernel::kPower) {
    m = std::pow(r + options_.epsilon, -options_.gamma);
  } else {
    const double zeta = options_.zeta > 0 ? options_.zeta : options_.radius / 2;
    m = std::exp(-r * r / (zeta * zeta));
  }
  return -m * d / r;
}

template <int D>
void VfcField<D>::check_grid(const Grid<D>& grid) const {
  double extent = 0;
  for (int a = 0; a < D; ++a) extent = std::max(extent, (grid.size[a] - 1) * grid.spacing[a]);
  if (options_.radius > extent)
    throw InputError("", "field.radius",
                     "VFC radius " + std::to_string(options_.radius) + " is larger than the image (largest extent " +
                         std::to_string(extent) + " in physical units)");
}

template <int D>
void VfcField<D>::compute(const Image<D>& image) {
  const Grid<D>& grid = image.grid();
  check_grid(grid);
  timings_ = {};
  const EdgeMap<D> edges = compute_edge_map(image, options_.edge, false, "vfc");
  vectors_ = VectorField<D>(grid);
  if (edges.f_max == 0) return;  // no edges: the zero field (warned by compute_edge_map)

  // Plans and kernel spectra, made once per grid geometry and thread count.
  const int threads = omp_get_max_threads();
  std::array<int, D> half{};  // kernel half-width in voxels per axis
  // (the kernel's 1e-9 margin: a spacing a rounding error above a round value keeps the half-width)
  for (int a = 0; a < D; ++a) half[a] = int(std::floor(options_.radius * (1 + 1e-9) / grid.spacing[a]));
  if (!fft_ || !fft_->grid.same_geometry(grid, 0.0) || fft_->threads != threads) {
    auto t0 = std::chrono::steady_clock::now();
    init_fftw_threads();
    auto fft = std::make_unique<Fft>();
    fft->plan(grid, threads, half);
    timings_.plan_s = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    fft->make_kernel_spectra(*this, half);
    timings_.kernel_s = seconds_since(t0);
    fft_ = std::move(fft);
  }

  // F_a = IFFT(FFT(f) * FFT(k_a)) / N, cropped to the image.
  const auto t0 = std::chrono::steady_clock::now();
  fft_->convolve(grid, edges.f.data(), vectors_);
  timings_.convolve_s = seconds_since(t0);
}

template <int D>
Point<D> VfcField<D>::force(const Point<D>& x, const Point<D>&) const {
  DSNAKE_ASSERT(!vectors_.empty(), "compute() before force()");
  return vectors_.sample(x);
}

template <int D>
std::string VfcField<D>::save_state() const {
  StateWriter w("dsnake-vfc-2");
  w.grid(vectors_.grid());
  w.vectors(vectors_);
  return std::move(w).bytes();
}

template <int D>
bool VfcField<D>::load_state(const Grid<D>& grid, const std::string& bytes) {
  StateReader r(bytes, "dsnake-vfc-2");
  if (!r.grid(grid)) return false;
  VectorField<D> v = r.vectors(grid);
  if (!r.ok()) return false;
  vectors_ = std::move(v);
  return true;
}

template class VfcField<2>;
template class VfcField<3>;

}  // namespace dsnake
