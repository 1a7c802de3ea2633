// Distance-potential field; see distance.h (Cohen & Cohen 1993; D-Snake §1).
#include "fields/distance.h"

#include "fields/field_state.h"
#include "framework/core/errors.h"
#include "framework/core/image_filters.h"

#include <cmath>
#include <limits>

namespace dsnake {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One axis of the transform: d[i] = min_j (f[j] + ((i - j) h)^2) for a line of n samples
// (Felzenszwalb & Huttenlocher, "Distance transforms of sampled functions", 2012, Alg. 1),
// positions i h. v, z: scratch of sizes n and n + 1.
void transform_line(double* f, int n, int64_t stride, double h, std::vector<double>& out, std::vector<int>& v,
                    std::vector<double>& z) {
  int k = -1;
  for (int q = 0; q < n; ++q) {
    const double fq = f[q * stride];
    if (fq == kInf) continue;
    const double pq = q * h;
    double s = -kInf;
    while (k >= 0) {
      const double pv = v[k] * h;
      s = ((fq + pq * pq) - (f[v[k] * stride] + pv * pv)) / (2 * (pq - pv));
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -kInf : s;
    z[k + 1] = kInf;
  }
  if (k < 0) return;  // no finite value on this line: stays infinite
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < q * h) ++j;
    const double d = (q - v[j]) * h;
    out[q] = d * d + f[v[j] * stride];
  }
  for (int q = 0; q < n; ++q) f[q * stride] = out[q];
}

}  // namespace

template <int D>
std::vector<double> squared_distance_transform(const Grid<D>& grid, const std::vector<bool>& site) {
  const int64_t n = grid.num_voxels();
  std::vector<double> d(n);
  for (int64_t l = 0; l < n; ++l) d[l] = site[l] ? 0.0 : kInf;
  int64_t stride = 1;
  for (int a = 0; a < D; ++a) {
    const int len = grid.size[a];
    const int64_t lines = n / len;
#pragma omp parallel
    {
      std::vector<double> out(len), z(len + 1);
      std::vector<int> v(len);
#pragma omp for schedule(static)
      for (int64_t line = 0; line < lines; ++line) {
        // The line's first voxel: index `line` with axis a removed.
        const int64_t below = line % stride, above = line / stride;
        transform_line(d.data() + above * stride * len + below, len, stride, grid.spacing[a], out, v, z);
      }
    }
    stride *= len;
  }
  return d;
}

template <int D>
DistanceField<D>::DistanceField(const DistanceFieldOptions& options) : options_(checked(options, kType)) {}

template <int D>
void DistanceField<D>::compute(const Image<D>& image) {
  const EdgeMap<D> edges = compute_edge_map(image, options_.edge, false, "distance");
  const Grid<D>& grid = edges.grid;
  const int64_t n = grid.num_voxels();
  distance_ = Image<D>(grid);
  vectors_ = VectorField<D>(grid);
  if (edges.f_max == 0) return;  // no edges: zero (warned by compute_edge_map)
  std::vector<bool> site(n);
  const double cut = options_.threshold * edges.f_max;
  for (int64_t l = 0; l < n; ++l) site[l] = edges.f[l] >= cut;
  std::vector<double> d = squared_distance_transform(grid, site);
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) d[l] = std::sqrt(d[l]);
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    distance_[l] = static_cast<float>(d[l]);
    for (int a = 0; a < D; ++a) vectors_.at(l)[a] = float(-partial_derivative(grid, d, l, a));
  }
}

template <int D>
Point<D> DistanceField<D>::force(const Point<D>& x, const Point<D>&) const {
  DSNAKE_ASSERT(!vectors_.empty(), "compute() before force()");
  return vectors_.sample(x);
}

template <int D>
double DistanceField<D>::potential(const Point<D>& x) const {
  DSNAKE_ASSERT(!distance_.empty(), "compute() before potential()");
  return distance_.sample(x);
}

template <int D>
std::string DistanceField<D>::save_state() const {
  StateWriter w("dsnake-distance-2");
  w.grid(vectors_.grid());
  w.array(distance_.data());
  w.vectors(vectors_);
  return std::move(w).bytes();
}

template <int D>
bool DistanceField<D>::load_state(const Grid<D>& grid, const std::string& bytes) {
  StateReader r(bytes, "dsnake-distance-2");
  if (!r.grid(grid)) return false;
  std::vector<float> d = r.array<float>();
  VectorField<D> v = r.vectors(grid);
  if (!r.ok() || int64_t(d.size()) != grid.num_voxels()) return false;
  distance_ = Image<D>(grid, std::move(d));
  vectors_ = std::move(v);
  return true;
}

template class DistanceField<2>;
template class DistanceField<3>;
template std::vector<double> squared_distance_transform(const Grid<2>&, const std::vector<bool>&);
template std::vector<double> squared_distance_transform(const Grid<3>&, const std::vector<bool>&);

}  // namespace dsnake
