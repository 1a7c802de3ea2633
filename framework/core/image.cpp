#include "framework/core/image.h"

#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dsnake {

template <int D>
int64_t Grid<D>::num_voxels() const {
  int64_t n = 1;
  for (int a = 0; a < D; ++a) n *= size[a];
  return n;
}

template <int D>
int64_t Grid<D>::linear(const GridIndex<D>& idx) const {
  int64_t l = idx[D - 1];
  for (int a = D - 2; a >= 0; --a) l = l * size[a] + idx[a];
  return l;
}

template <int D>
GridIndex<D> Grid<D>::index(int64_t l) const {
  GridIndex<D> idx;
  for (int a = 0; a < D; ++a) {
    idx[a] = static_cast<int>(l % size[a]);
    l /= size[a];
  }
  return idx;
}

template <int D>
Point<D> Grid<D>::to_physical(const GridIndex<D>& idx) const {
  return origin + idx.template cast<double>().cwiseProduct(spacing);
}

template <int D>
Point<D> Grid<D>::to_continuous_index(const Point<D>& x) const {
  return (x - origin).cwiseQuotient(spacing);
}

template <int D>
bool Grid<D>::inside(const Point<D>& x) const {
  const Point<D> c = to_continuous_index(x);
  for (int a = 0; a < D; ++a)
    if (!(c[a] >= 0.0 && c[a] <= size[a] - 1)) return false;
  return true;
}

template <int D>
bool Grid<D>::same_geometry(const Grid& o, double tol) const {
  return size == o.size && (spacing - o.spacing).cwiseAbs().maxCoeff() <= tol &&
         (origin - o.origin).cwiseAbs().maxCoeff() <= tol && (direction - o.direction).cwiseAbs().maxCoeff() <= tol;
}

namespace {

// The linear stencil's base voxel around x (clamped to the grid), the offsets from it to the
// upper neighbour along each axis (0 on an axis of one voxel) and the fractions t_a; shared by
// Grid::stencil and VectorField::prefetch.
template <int D>
[[gnu::always_inline]] inline int64_t stencil_base(const Grid<D>& g, const Point<D>& x, std::array<int64_t, D>& step, std::array<double, D>& t) {
  int64_t base = 0, stride = 1;
  for (int a = 0; a < D; ++a) {
    const double c = (x[a] - g.origin[a]) / g.spacing[a];
    const double ca = std::clamp(std::isfinite(c) ? c : 0.0, 0.0, double(g.size[a] - 1));
    const int lo = std::min(static_cast<int>(std::floor(ca)), std::max(g.size[a] - 2, 0));
    t[a] = ca - lo;
    base += lo * stride;
    step[a] = g.size[a] > 1 ? stride : 0;
    stride *= g.size[a];
  }
  return base;
}

}  // namespace

// Clamped corner indices lo..lo+1 per axis (lo + 1 = lo on an axis of one voxel) and the weights
// w_k = prod_a (bit_a(k) ? t_a : 1 - t_a), multiplied in axis order. The corners are offsets from
// the base voxel, so the per-corner work is one add (the sampling loops of every field force).
template <int D>
typename Grid<D>::Stencil Grid<D>::stencil(const Point<D>& x) const {
  Stencil s;
  std::array<int64_t, D> step;
  std::array<double, D> t;
  const int64_t base = stencil_base<D>(*this, x, step, t);
  constexpr int kCorners = D == 2 ? 4 : 8;
  for (int k = 0; k < kCorners; ++k) {
    int64_t voxel = base;
    double w = 1.0;
    for (int a = 0; a < D; ++a) {
      const int bit = (k >> a) & 1;
      voxel += bit * step[a];
      w *= bit ? t[a] : 1.0 - t[a];
    }
    s.voxel[k] = voxel;
    s.weight[k] = w;
  }
  return s;
}

template <int D>
Image<D>::Image(const Grid<D>& grid, float value) : grid_(grid), data_(grid.num_voxels(), value) {}

template <int D>
Image<D>::Image(const Grid<D>& grid, std::vector<float>&& data) : grid_(grid), data_(std::move(data)) {
  DSNAKE_ASSERT(int64_t(data_.size()) == grid_.num_voxels(), "one value per voxel of the grid");
}

template <int D>
double Image<D>::sample(const Point<D>& x) const {
  const auto s = grid_.stencil(x);
  double v = 0.0;
  for (size_t k = 0; k < s.voxel.size(); ++k) v += s.weight[k] * data_[s.voxel[k]];
  return v;
}

template <int D>
void Image<D>::sample_lattice(const Point<D>& x, double h, int half, double* out) const {
  const int w = 2 * half + 1;
  // Per axis and lattice index: the base voxel's offset, the step to its upper neighbour and
  // the weight t, exactly as stencil_base() computes them for a single point.
  std::vector<int64_t> base(static_cast<size_t>(D * w)), step(static_cast<size_t>(D * w));
  std::vector<double> t(static_cast<size_t>(D * w));
  int64_t stride = 1;
  for (int a = 0; a < D; ++a) {
    for (int i = 0; i < w; ++i) {
      const double xa = x[a] + h * double(i - half);
      const double c = (xa - grid_.origin[a]) / grid_.spacing[a];
      const double ca = std::clamp(std::isfinite(c) ? c : 0.0, 0.0, double(grid_.size[a] - 1));
      const int lo = std::min(static_cast<int>(std::floor(ca)), std::max(grid_.size[a] - 2, 0));
      t[a * w + i] = ca - lo;
      base[a * w + i] = lo * stride;
      step[a * w + i] = grid_.size[a] > 1 ? stride : 0;
    }
    stride *= grid_.size[a];
  }
  constexpr int kCorners = D == 2 ? 4 : 8;
  int64_t total = 1;
  for (int a = 0; a < D; ++a) total *= w;
  for (int64_t k = 0; k < total; ++k) {
    int idx[D];
    int64_t r = k, b = 0;
    for (int a = 0; a < D; ++a) {
      idx[a] = int(r % w);
      r /= w;
      b += base[a * w + idx[a]];
    }
    double v = 0.0;
    for (int c = 0; c < kCorners; ++c) {
      int64_t voxel = b;
      double wt = 1.0;
      for (int a = 0; a < D; ++a) {
        const int bit = (c >> a) & 1;
        voxel += bit * step[a * w + idx[a]];
        wt *= bit ? t[a * w + idx[a]] : 1.0 - t[a * w + idx[a]];
      }
      v += wt * data_[voxel];
    }
    out[k] = v;
  }
}

template <int D>
void Image<D>::prefetch(const Point<D>& x) const {
  if (data_.empty()) return;
  // the stencil's base voxel and its x neighbour (one line, or two when the pair straddles one)
  std::array<int64_t, D> step;
  std::array<double, D> t;
  const char* p = reinterpret_cast<const char*>(data_.data() + stencil_base<D>(grid_, x, step, t));
  for (int k = 0; k < (1 << (D - 1)); ++k) {
    int64_t offset = 0;
    for (int a = 1; a < D; ++a) offset += ((k >> (a - 1)) & 1) * step[a];
    __builtin_prefetch(p + offset * int64_t(sizeof(float)));
    __builtin_prefetch(p + offset * int64_t(sizeof(float)) + 2 * sizeof(float) - 1);
  }
}

template <int D>
VectorField<D>::VectorField(const Grid<D>& grid)
    : grid_(grid), values_(size_t(grid.num_voxels()) * D, 0.0f) {}

template <int D>
Point<D> VectorField<D>::sample(const Point<D>& x) const {
  const auto s = grid_.stencil(x);
  Point<D> v = Point<D>::Zero();
  for (size_t k = 0; k < s.voxel.size(); ++k) {
    const float* p = values_.data() + size_t(s.voxel[k]) * D;
    for (int a = 0; a < D; ++a) v[a] += s.weight[k] * double(p[a]);
  }
  return v;
}

template <int D>
void VectorField<D>::prefetch(const Point<D>& x) const {
  if (values_.empty()) return;
  // the stencil's base voxel only (no weights): its x neighbour shares the line or the next one
  std::array<int64_t, D> step;
  std::array<double, D> t;
  const int64_t base = stencil_base<D>(grid_, x, step, t);
  const char* p = reinterpret_cast<const char*>(values_.data() + base * D);
  for (int k = 0; k < (1 << (D - 1)); ++k) {
    int64_t offset = 0;
    for (int a = 1; a < D; ++a) offset += ((k >> (a - 1)) & 1) * step[a];
    __builtin_prefetch(p + offset * int64_t(D * sizeof(float)));
    __builtin_prefetch(p + offset * int64_t(D * sizeof(float)) + 2 * D * sizeof(float) - 1);
  }
}

template <int D>
Image<D> VectorField<D>::component(int axis) const {
  Image<D> img(grid_);
  for (int64_t i = 0; i < num_voxels(); ++i) img[i] = values_[size_t(i) * D + axis];
  return img;
}

template struct Grid<2>;
template struct Grid<3>;
template <int D>
BinaryMask<D>::BinaryMask(const Grid<D>& grid, std::vector<uint8_t>&& inside) : grid_(grid), inside_(std::move(inside)) {
  DSNAKE_ASSERT(static_cast<int64_t>(inside_.size()) == grid_.num_voxels(), "one value per voxel");
}

template <int D>
BinaryMask<D>::BinaryMask(const Image<D>& image) : grid_(image.grid()), inside_(image.data().size()) {
  const std::vector<float>& v = image.data();
  for (size_t l = 0; l < v.size(); ++l) inside_[l] = v[l] != 0.0f;
}

template <int D>
BinaryMask<D> resample_along(const BinaryMask<D>& mask, const Eigen::Matrix<double, D, D>& direction) {
  const Grid<D>& m = mask.grid();
  // The inside voxels' box in the mask's indices, and its corners (half a voxel out) in the new
  // axes' coordinates u = direction^T world.
  GridIndex<D> lo = m.size, hi = GridIndex<D>::Constant(-1);
  for (int64_t l = 0; l < mask.num_voxels(); ++l) {
    if (!mask[l]) continue;
    const GridIndex<D> idx = m.index(l);
    lo = lo.cwiseMin(idx);
    hi = hi.cwiseMax(idx);
  }
  Grid<D> out;
  out.direction = direction;
  if ((hi.array() < 0).any()) {  // nothing inside: one empty voxel where the mask's origin is
    out.size.setOnes();
    out.spacing = m.spacing;
    out.origin = m.origin;
    return BinaryMask<D>(out, std::vector<uint8_t>(1, 0));
  }
  Point<D> ulo = Point<D>::Constant(std::numeric_limits<double>::infinity()), uhi = -ulo;
  for (int corner = 0; corner < (1 << D); ++corner) {
    Point<D> frame;
    for (int a = 0; a < D; ++a) frame[a] = m.origin[a] + m.spacing[a] * ((corner >> a & 1) ? hi[a] + 0.5 : lo[a] - 0.5);
    const Point<D> u = direction.transpose() * m.to_world(frame);
    ulo = ulo.cwiseMin(u);
    uhi = uhi.cwiseMax(u);
  }
  double box_voxels = 1, h = m.spacing.minCoeff();
  for (int a = 0; a < D; ++a) box_voxels *= double(hi[a] - lo[a] + 1);
  auto count = [&](double s) {
    double n = 1;
    for (int a = 0; a < D; ++a) n *= std::ceil((uhi[a] - ulo[a]) / s);
    return n;
  };
  if (count(h) > 32 * box_voxels) h *= std::pow(count(h) / (32 * box_voxels), 1.0 / D);
  out.spacing = Point<D>::Constant(h);
  for (int a = 0; a < D; ++a) out.size[a] = std::max(1, static_cast<int>(std::ceil((uhi[a] - ulo[a]) / h)));
  // Voxel 0's centre half a voxel inside the box; the grid's frame is the new axes about its origin.
  const Point<D> u0 = ulo + Point<D>::Constant(h / 2);
  out.origin = direction * u0;
  std::vector<uint8_t> inside(static_cast<size_t>(out.num_voxels()), 0);
  for (int64_t l = 0; l < out.num_voxels(); ++l) {
    const Point<D> x = m.to_frame(out.to_world(out.to_physical(out.index(l))));
    const Point<D> c = m.to_continuous_index(x);
    bool within = true;
    for (int a = 0; a < D; ++a) within = within && c[a] >= 0 && c[a] <= m.size[a] - 1;
    if (!within) continue;
    const auto s = m.stencil(x);
    double v = 0;
    for (size_t k = 0; k < s.voxel.size(); ++k) v += s.weight[k] * double(mask[s.voxel[k]]);
    inside[size_t(l)] = v >= 0.5;
  }
  return BinaryMask<D>(out, std::move(inside));
}

template class Image<2>;
template class Image<3>;
template class BinaryMask<2>;
template class BinaryMask<3>;
template BinaryMask<2> resample_along<2>(const BinaryMask<2>&, const Eigen::Matrix<double, 2, 2>&);
template BinaryMask<3> resample_along<3>(const BinaryMask<3>&, const Eigen::Matrix<double, 3, 3>&);
template class VectorField<2>;
template class VectorField<3>;

}  // namespace dsnake
