// Potentials for the global solve and their smooth interpolation; see potential.h (Levi &
// Gotsman, D-Snake §1-§2 for the fields these potentials stand in for).
#include "fields/smooth_potential.h"

#include "fields/distance.h"
#include "fields/edge_map.h"
#include "framework/core/errors.h"
#include "framework/core/json_reader.h"

#include <ceres/cubic_interpolation.h>
#include <fftw3.h>  // double precision (fftw_*)

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

namespace dsnake {

namespace {

constexpr double kPi = 3.14159265358979323846;

// FFTW's planner (plan creation and destruction) is not thread-safe; execution is.
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}

struct FftwFree {
  void operator()(double* p) const { fftw_free(p); }
};
using FftwBuffer = std::unique_ptr<double, FftwFree>;

// Lines transformed per FFTW call: gathering several neighbouring lines reads memory in runs.
constexpr int kBatch = 16;

// Applies the 1D real-to-real transform `kind` (unnormalised, FFTW's definition) along `axis`
// to every grid line of `data` (x fastest). One single-threaded plan for a batch of kBatch
// lines, executed on per-thread buffers: line l always goes through the same batch slot, so the
// result does not depend on the number of threads.
template <int D>
void transform_axis(const Grid<D>& grid, std::vector<double>& data, int axis, fftw_r2r_kind kind) {
  const int len = grid.size[axis];
  int64_t stride = 1;
  for (int a = 0; a < axis; ++a) stride *= grid.size[a];
  const int64_t lines = grid.num_voxels() / len;
  const int64_t batches = (lines + kBatch - 1) / kBatch;
  fftw_plan plan;
  {
    std::lock_guard<std::mutex> lock(planner_mutex());
    FftwBuffer scratch(fftw_alloc_real(size_t(kBatch) * len));
    plan = fftw_plan_many_r2r(1, &len, kBatch, scratch.get(), nullptr, 1, len, scratch.get(), nullptr, 1, len,
                              &kind, FFTW_ESTIMATE);
  }
  DSNAKE_ASSERT(plan != nullptr, "FFTW could not plan the DCT");
#pragma omp parallel
  {
    FftwBuffer buffer(fftw_alloc_real(size_t(kBatch) * len));
    double* buf = buffer.get();
    int64_t start[kBatch];
#pragma omp for schedule(static)
    for (int64_t batch = 0; batch < batches; ++batch) {
      const int count = int(std::min<int64_t>(kBatch, lines - batch * kBatch));
      for (int b = 0; b < count; ++b) {
        const int64_t line = batch * kBatch + b;
        start[b] = (line / stride) * stride * len + line % stride;  // first voxel of the line
      }
      for (int j = 0; j < len; ++j)
        for (int b = 0; b < count; ++b) buf[int64_t(b) * len + j] = data[start[b] + j * stride];
      std::fill(buf + int64_t(count) * len, buf + int64_t(kBatch) * len, 0.0);
      fftw_execute_r2r(plan, buf, buf);
      for (int j = 0; j < len; ++j)
        for (int b = 0; b < count; ++b) data[start[b] + j * stride] = buf[int64_t(b) * len + j];
    }
  }
  std::lock_guard<std::mutex> lock(planner_mutex());
  fftw_destroy_plan(plan);
}

// Shifts `values` so that their minimum is 0 (exact: min is order-independent).
void shift_to_zero_min(std::vector<double>& values) {
  double lo = std::numeric_limits<double>::infinity();
  for (double v : values) lo = std::min(lo, v);
  const int64_t n = int64_t(values.size());
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) values[l] -= lo;
}

// The edge potential (§1): P = max f - f for the normalised edge map f = |grad(G_sigma*I)|^2.
template <int D>
Image<D> edge_potential(const Image<D>& image, double sigma) {
  const EdgeMap<D> edges = compute_edge_map(image, EdgeMapOptions{sigma, true}, false, "edge potential");
  Image<D> p(image.grid());
  if (edges.f_max == 0) return p;  // no edges: zero (warned by compute_edge_map)
  float f_max = 0.0f;
  for (float f : edges.f) f_max = std::max(f_max, f);
  const int64_t n = p.num_voxels();
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) p[l] = f_max - edges.f[l];
  return p;
}

// The distance potential (Cohen & Cohen 1993; D-Snake §1): distance to the nearest edge voxel,
// with DistanceField's edge definition (normalised edge map >= 0.5 of its maximum).
template <int D>
Image<D> distance_potential(const Image<D>& image, double sigma) {
  DistanceFieldOptions o;
  o.edge.sigma = sigma;
  o.edge.normalize = true;
  DistanceField<D> field(o);
  field.compute(image);
  return field.distance();
}

}  // namespace

// Least-squares integration (see potential.h): right-hand side D^T g, DCT-II on every axis,
// division by the Neumann Laplacian's eigenvalues, DCT-III back, normalisation, shift.
template <int D>
std::vector<double> integrate_field(const VectorField<D>& field) {
  const Grid<D>& grid = field.grid();
  const int64_t n = grid.num_voxels();
  DSNAKE_ASSERT(n > 0, "integrate_field: a non-empty field");
  std::array<int64_t, D> stride;
  stride[0] = 1;
  for (int a = 1; a < D; ++a) stride[a] = stride[a - 1] * grid.size[a - 1];
  // b = D^T g with g(x -> x + e_a) = -(F_a[x] + F_a[x + e_a]) / 2: each edge gives +g / h_a to
  // its head and -g / h_a to its tail (interior: the central-difference divergence of F).
  std::vector<double> p(n);
  const int nx = grid.size[0];
  const int64_t rows = n / nx;  // grid lines along x; one index computation per line
#pragma omp parallel for schedule(static)
  for (int64_t row = 0; row < rows; ++row) {
    GridIndex<D> idx = grid.index(row * nx);
    for (int i = 0; i < nx; ++i) {
      idx[0] = i;
      const int64_t l = row * nx + i;
      double b = 0.0;
      for (int a = 0; a < D; ++a) {
        const double fa = field[l][a], h = grid.spacing[a];
        if (idx[a] > 0) b -= 0.5 * (field[l - stride[a]][a] + fa) / h;
        if (idx[a] + 1 < grid.size[a]) b += 0.5 * (fa + field[l + stride[a]][a]) / h;
      }
      p[l] = b;
    }
  }
  for (int a = 0; a < D; ++a) transform_axis(grid, p, a, FFTW_REDFT10);
  // Eigenvalues of the 1D Neumann operator (-1, 2, -1) / h^2 for the DCT-II basis
  // cos(pi k (i + 1/2) / N); the inverse DCT (REDFT01) of REDFT10 scales by 2N per axis.
  std::array<std::vector<double>, D> eigen;
  double scale = 1.0;
  for (int a = 0; a < D; ++a) {
    const int len = grid.size[a];
    eigen[a].resize(len);
    for (int k = 0; k < len; ++k) {
      const double s = std::sin(kPi * k / (2.0 * len));
      eigen[a][k] = 4.0 * s * s / (grid.spacing[a] * grid.spacing[a]);
    }
    scale *= 2.0 * len;
  }
#pragma omp parallel for schedule(static)
  for (int64_t row = 0; row < rows; ++row) {
    const GridIndex<D> k = grid.index(row * nx);
    double lambda_row = 0.0;  // the eigenvalue part of the axes other than x
    for (int a = 1; a < D; ++a) lambda_row += eigen[a][k[a]];
    for (int i = 0; i < nx; ++i) {
      const int64_t l = row * nx + i;
      p[l] = l == 0 ? 0.0 : p[l] / ((eigen[0][i] + lambda_row) * scale);  // constant mode: zero mean
    }
  }
  for (int a = 0; a < D; ++a) transform_axis(grid, p, a, FFTW_REDFT01);
  shift_to_zero_min(p);
  return p;
}

template <int D>
Image<D> compute_potential(const PotentialOptions& options, const Image<D>& image, const ExternalField<D>* field) {
  checked(options, "potential");
  if (options.type != PotentialType::kIntegrated)
    DSNAKE_ASSERT(image.num_voxels() > 0, "compute_potential: a non-empty image");
  if (options.type == PotentialType::kEdge) return edge_potential(image, options.sigma);
  if (options.type == PotentialType::kDistance) return distance_potential(image, options.sigma);
  DSNAKE_ASSERT(options.type == PotentialType::kIntegrated, "potential options: type is edge, distance or integrated");
  DSNAKE_ASSERT(field != nullptr, "the integrated potential needs a field");
  const VectorField<D>& vectors = field->vectors();
  DSNAKE_ASSERT(!vectors.empty() && (image.num_voxels() == 0 || vectors.grid().same_geometry(image.grid())),
                "the integrated potential needs a field computed on the image");
  const std::vector<double> p = integrate_field(vectors);
  Image<D> out(vectors.grid());
  const int64_t n = out.num_voxels();
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) out[l] = static_cast<float>(p[l]);
  return out;
}

// ---------------------------------------------------------------------------------------------
// SmoothPotential

namespace {

// Catmull-Rom weights of the four samples p0..p3 at t in [0, 1) and their derivatives: the
// polynomial of ceres::CubicHermiteSpline (Keys' cubic convolution kernel, a = -0.5) regrouped
// by sample.
void catmull_rom_weights(double t, double w[4], double dw[4]) {
  const double t2 = t * t, t3 = t2 * t;
  w[0] = 0.5 * (-t3 + 2 * t2 - t);
  w[1] = 0.5 * (3 * t3 - 5 * t2) + 1.0;
  w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
  w[3] = 0.5 * (t3 - t2);
  dw[0] = 0.5 * (-3 * t2 + 4 * t - 1);
  dw[1] = 0.5 * (9 * t2 - 10 * t);
  dw[2] = 0.5 * (-9 * t2 + 8 * t + 1);
  dw[3] = 0.5 * (3 * t2 - 2 * t);
}

using CeresGrid = ceres::Grid2D<double, 1>;
using CeresBicubic = ceres::BiCubicInterpolator<CeresGrid>;

}  // namespace

template <int D>
struct SmoothPotential<D>::Impl {
  Grid<D> grid;
  std::string interpolation;
  // The values: doubles, or (3D, built from an image, whose voxels are floats) the floats
  // themselves, the same numbers in half the memory (each is widened exactly where it is read).
  std::vector<double> values;
  std::vector<float> single;
  bool cubic = true;
  std::unique_ptr<CeresGrid> ceres_grid;  // D = 2, cubic: views `values` (row = y, col = x)
  std::unique_ptr<CeresBicubic> bicubic;

  Impl(const Grid<D>& g, std::vector<double> v, std::vector<float> f, const std::string& interp)
      : grid(g), interpolation(interp), values(std::move(v)), single(std::move(f)) {
    DSNAKE_ASSERT(interp == "cubic" || interp == "linear", "interpolation is \"cubic\" or \"linear\"");
    DSNAKE_ASSERT(grid.num_voxels() > 0 && int64_t(values.size() + single.size()) == grid.num_voxels() &&
                      (values.empty() || single.empty()) && (D == 3 || single.empty()),
                  "one potential value per voxel");
    cubic = interp == "cubic";
    if constexpr (D == 2) {
      if (cubic) {
        ceres_grid = std::make_unique<CeresGrid>(values.data(), 0, grid.size[1], 0, grid.size[0]);
        bicubic = std::make_unique<CeresBicubic>(*ceres_grid);
      }
    }
  }

  // Continuous voxel index of x along axis a, clamped to [-2, N_a]: beyond that range every
  // clamped sample index is the border voxel, so the cubic is constant there and clamping
  // changes nothing but keeps floor() within int range.
  double cubic_index(const Point<D>& x, int a) const {
    const double u = (x[a] - grid.origin[a]) / grid.spacing[a];
    return std::clamp(u, -2.0, double(grid.size[a]));
  }

  // Tricubic (3D) or bicubic via Ceres (2D) Catmull-Rom value and gradient (per voxel index).
  double eval_cubic(const Point<D>& x, Point<D>& du) const {
    if constexpr (D == 2) {
      double f, dfdr, dfdc;
      bicubic->Evaluate(cubic_index(x, 1), cubic_index(x, 0), &f, &dfdr, &dfdc);
      du = Point<2>(dfdc, dfdr);
      return f;
    } else {
      return single.empty() ? tricubic(values.data(), x, du) : tricubic(single.data(), x, du);
    }
  }

  template <class T>
  double tricubic(const T* data, const Point<D>& x, Point<D>& du) const {
    if constexpr (D == 3) {
      int64_t index[3][4];
      double w[3][4], dw[3][4];
      for (int a = 0; a < 3; ++a) {
        const double u = cubic_index(x, a);
        const int base = int(std::floor(u));
        catmull_rom_weights(u - base, w[a], dw[a]);
        int64_t stride = 1;
        for (int b = 0; b < a; ++b) stride *= grid.size[b];
        for (int k = 0; k < 4; ++k) index[a][k] = std::clamp(base - 1 + k, 0, grid.size[a] - 1) * stride;
      }
      double f = 0, fx = 0, fy = 0, fz = 0;
      for (int k = 0; k < 4; ++k) {
        double sf = 0, sx = 0, sy = 0;  // the z-slice k, interpolated in x and y
        for (int j = 0; j < 4; ++j) {
          const T* row = data + index[2][k] + index[1][j];
          double r = 0, rx = 0;
          for (int i = 0; i < 4; ++i) {
            const double v = row[index[0][i]];
            r += w[0][i] * v;
            rx += dw[0][i] * v;
          }
          sf += w[1][j] * r;
          sx += w[1][j] * rx;
          sy += dw[1][j] * r;
        }
        f += w[2][k] * sf;
        fx += w[2][k] * sx;
        fy += w[2][k] * sy;
        fz += dw[2][k] * sf;
      }
      du = Point<3>(fx, fy, fz);
      return f;
    }
    return 0.0;
  }

  // (Bi/tri)linear value and gradient (per voxel index) in the cell containing the clamped x;
  // the gradient is zero along an axis where x lies outside the grid (the value is constant).
  double eval_linear(const Point<D>& x, Point<D>& du) const {
    return single.empty() ? linear(values.data(), x, du) : linear(single.data(), x, du);
  }

  template <class T>
  double linear(const T* data, const Point<D>& x, Point<D>& du) const {
    std::array<int64_t, D> lo, hi;
    std::array<double, D> t;
    std::array<bool, D> inside;
    int64_t stride = 1;
    for (int a = 0; a < D; ++a) {
      const int len = grid.size[a];
      const double u = (x[a] - grid.origin[a]) / grid.spacing[a];
      inside[a] = u >= 0 && u <= len - 1;
      const double uc = std::clamp(u, 0.0, double(len - 1));
      const int i0 = std::min(int(std::floor(uc)), std::max(len - 2, 0));
      const int i1 = std::min(i0 + 1, len - 1);
      t[a] = uc - i0;
      lo[a] = i0 * stride;
      hi[a] = i1 * stride;
      stride *= len;
    }
    double f = 0;
    Point<D> g = Point<D>::Zero();
    for (int corner = 0; corner < (1 << D); ++corner) {
      int64_t l = 0;
      double weight = 1.0;
      Point<D> dweight;
      for (int a = 0; a < D; ++a) {
        const bool up = (corner >> a) & 1;
        l += up ? hi[a] : lo[a];
        weight *= up ? t[a] : 1.0 - t[a];
      }
      for (int a = 0; a < D; ++a) {
        double d = ((corner >> a) & 1) ? 1.0 : -1.0;
        for (int b = 0; b < D; ++b)
          if (b != a) d *= ((corner >> b) & 1) ? t[b] : 1.0 - t[b];
        dweight[a] = d;
      }
      const double v = data[l];
      f += weight * v;
      g += dweight * v;
    }
    for (int a = 0; a < D; ++a)
      if (!inside[a] || grid.size[a] == 1) g[a] = 0.0;
    du = g;
    return f;
  }
};

template <int D>
SmoothPotential<D>::SmoothPotential(const Image<D>& values, const std::string& interpolation)
    : impl_(D == 3 ? std::make_shared<const Impl>(values.grid(), std::vector<double>(),
                                                  std::vector<float>(values.data().begin(), values.data().end()),
                                                  interpolation)
                   : std::make_shared<const Impl>(values.grid(),
                                                  std::vector<double>(values.data().begin(), values.data().end()),
                                                  std::vector<float>(), interpolation)) {}

template <int D>
SmoothPotential<D>::SmoothPotential(const Grid<D>& grid, std::vector<double> values, const std::string& interpolation)
    : impl_(std::make_shared<const Impl>(grid, std::move(values), std::vector<float>(), interpolation)) {}

template <int D>
const Grid<D>& SmoothPotential<D>::grid() const {
  return impl_->grid;
}

template <int D>
const std::string& SmoothPotential<D>::interpolation() const {
  return impl_->interpolation;
}

template <int D>
double SmoothPotential<D>::value(const Point<D>& x) const {
  Point<D> gradient;
  return value_and_gradient(x, gradient);
}

// Interpolates in voxel-index coordinates u = (x - origin) / spacing, then dP/dx = dP/du / h.
template <int D>
double SmoothPotential<D>::value_and_gradient(const Point<D>& x, Point<D>& gradient) const {
  if (!x.allFinite()) {
    gradient.setConstant(std::numeric_limits<double>::quiet_NaN());
    return std::numeric_limits<double>::quiet_NaN();
  }
  Point<D> du;
  const double f = impl_->cubic ? impl_->eval_cubic(x, du) : impl_->eval_linear(x, du);
  gradient = du.cwiseQuotient(impl_->grid.spacing);
  return f;
}

template Image<2> compute_potential(const PotentialOptions&, const Image<2>&, const ExternalField<2>*);
template Image<3> compute_potential(const PotentialOptions&, const Image<3>&, const ExternalField<3>*);
template std::vector<double> integrate_field(const VectorField<2>&);
template std::vector<double> integrate_field(const VectorField<3>&);
template class SmoothPotential<2>;
template class SmoothPotential<3>;

template <int D>
std::unique_ptr<SmoothPotential<D>> make_potential(const PotentialOptions& options, const Image<D>& image,
                                                   const ExternalField<D>* field) {
  return std::make_unique<SmoothPotential<D>>(compute_potential<D>(options, image, field),
                                              enum_name(options.interpolation));
}

template std::unique_ptr<SmoothPotential<2>> make_potential<2>(const PotentialOptions&, const Image<2>&,
                                                               const ExternalField<2>*);
template std::unique_ptr<SmoothPotential<3>> make_potential<3>(const PotentialOptions&, const Image<3>&,
                                                               const ExternalField<3>*);

}  // namespace dsnake
