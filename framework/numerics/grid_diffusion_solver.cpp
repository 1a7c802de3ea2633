// The multigrid-preconditioned GVF solver and the entry point; see grid_diffusion_solver.h. The explicit
// reference iteration is in explicit_diffusion.cpp, the shared grid view in diffusion_grid.h.
#include "framework/numerics/grid_diffusion_solver.h"

#include "framework/numerics/diffusion_grid.h"

#include "framework/core/errors.h"

#include <Eigen/Dense>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <utility>

namespace dsnake {

namespace {

using namespace gvf_detail;

// Eight floats, loaded and stored unaligned (the level arrays are not padded).
// typedef, not `using`: clang ignores a lowered alignment on an alias declaration (UBSan found the
// misaligned loads under clang; GCC honours both spellings).
typedef float Vec8 __attribute__((vector_size(32), aligned(4)));
using Vec8Index = int __attribute__((vector_size(32)));

// 1 / A_ii of voxel i of a row, computed where it is used rather than stored (4 bytes
// per voxel): A_ii = b_i + the weights of the neighbours that exist (side: the y and z ones,
// wl and wr: cx or 0 at the row's ends), summed in this order; 0 where A_ii is 0.
[[gnu::always_inline]] inline float inverse_diagonal(float b, float side, float wl, float wr) {
  const float diag = b + side + wl + wr;
  return diag > 0.f ? 1.f / diag : 0.f;
}
// The vector loops below do the same for eight interior voxels (both x neighbours), lane by lane
// (spelled out there: a function returning a vector would change the ABI outside the clones).

// The first half-sweep from v = 0 on one row: rhs / A_ii on the voxels x % 2 == first (their
// neighbours are all 0), 0 on the others (written, so that v need not be cleared beforehand).
// b: the row's weights; side: the sum of its y and z neighbour weights.
DSNAKE_VECTOR_CLONES
void start_row(float* __restrict u0, const float* __restrict f, const float* __restrict b, float side, float cx,
               int nx, int first) {
  auto one = [&](int i) {
    const float inv = inverse_diagonal(b[i], side, i > 0 ? cx : 0.f, i < nx - 1 ? cx : 0.f);
    u0[i] = (i & 1) == first ? f[i] * inv : 0.f;
  };
  one(0);
  const Vec8Index lane = {0, 1, 2, 3, 4, 5, 6, 7};
  const Vec8Index store = (lane & 1) != first;  // lane l of a vector at i % 8 == 1
  int i = 1;
  for (; i + 8 <= nx - 1; i += 8) {
    const Vec8 diag = *reinterpret_cast<const Vec8*>(b + i) + side + cx + cx;
    const Vec8 v = *reinterpret_cast<const Vec8*>(f + i) * (diag > 0.f ? 1.f / diag : Vec8{});
    *reinterpret_cast<Vec8*>(u0 + i) = store ? v : Vec8{};
  }
  for (; i < nx; ++i) one(i);
}

// Red-black Gauss-Seidel on one row of one field, the voxels from `first` in steps of 2:
// v_i = (rhs_i + sum_nb w v_nb) / A_ii, as a product with the level's 1 / A_ii. The interior
// runs on whole vectors of 8 voxels: every lane computes its update from the old row and only
// the lanes of the colour are stored (a voxel's update reads only the other colour, which this
// pass leaves alone, so this equals the voxel-by-voxel sweep); the x neighbours come from
// shuffles of the vectors already loaded, and each vector is loaded before the previous one is
// stored. The first voxel and the last 8 to 15 (end voxels have one x neighbour) go one by one.
// b: the row's weights (1 / A_ii is computed from them, see inverse_diagonal).
DSNAKE_VECTOR_CLONES
void smooth_row(float* u, const float* rhs, const float* __restrict b, const RowNeighbours& r, float cx, int nx,
                int first) {
  const float* __restrict f = rhs + r.row;
  float* __restrict u0 = u + r.row;
  const float *__restrict uym = u + r.ym, *__restrict uyp = u + r.yp, *__restrict uzm = u + r.zm,
              *__restrict uzp = u + r.zp;
  const float wym = r.wym, wyp = r.wyp, wzm = r.wzm, wzp = r.wzp, side = wym + wyp + wzm + wzp;
  // One voxel with its own x weights; a voxel without weight (inv 0) is left alone.
  auto one = [&](int i, float wl, float wr) {
    const float inv = inverse_diagonal(b[i], side, wl, wr);
    if (inv == 0.f) return;
    const float s = f[i] + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] +
                    (wl > 0 ? wl * u0[i - 1] : 0.f) + (wr > 0 ? wr * u0[i + 1] : 0.f);
    u0[i] = s * inv;
  };
  if (nx == 1) {
    if (first == 0) one(0, 0.f, 0.f);
    return;
  }
  if (first == 0) one(0, 0.f, cx);
  // Vectors at x = i .. i + 7 for i = 1, 9, ... while the next vector (i + 8 .. i + 15) is in
  // the row: lane l is stored when (i + l) % 2 == first, i.e. when l % 2 != first. (Loads are
  // spelled out: a lambda would be compiled for the default target, outside the AVX2 clone.)
  const Vec8Index lane = {0, 1, 2, 3, 4, 5, 6, 7};
  const Vec8Index store = (lane & 1) != first;
  int i = 1;
  if (nx >= 17) {
    Vec8 left = *reinterpret_cast<const Vec8*>(u0), c = *reinterpret_cast<const Vec8*>(u0 + 1);
    for (; i + 16 <= nx; i += 8) {
      const Vec8 next = *reinterpret_cast<const Vec8*>(u0 + i + 8);
      const Vec8 right = DSNAKE_SHUFFLE2(c, next, Vec8Index, 1, 2, 3, 4, 5, 6, 7, 8);
      const Vec8 s = *reinterpret_cast<const Vec8*>(f + i) + cx * (left + right) +
                     wym * *reinterpret_cast<const Vec8*>(uym + i) + wyp * *reinterpret_cast<const Vec8*>(uyp + i) +
                     wzm * *reinterpret_cast<const Vec8*>(uzm + i) + wzp * *reinterpret_cast<const Vec8*>(uzp + i);
      const Vec8 diag = *reinterpret_cast<const Vec8*>(b + i) + side + cx + cx;
      const Vec8 v = s * (diag > 0.f ? 1.f / diag : Vec8{});
      *reinterpret_cast<Vec8*>(u0 + i) = store ? v : c;
      left = DSNAKE_SHUFFLE2(c, next, Vec8Index, 7, 8, 9, 10, 11, 12, 13, 14);
      c = next;
    }
  }
  for (i += (i & 1) != first ? 1 : 0; i < nx - 1; i += 2) {
    const float s = f[i] + cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i];
    u0[i] = s * inverse_diagonal(b[i], side, cx, cx);
  }
  if (((nx - 1) & 1) == first) one(nx - 1, cx, 0.f);
}

// out = rhs - A u (kResidual) or out = A u on one row, A u = b u + sum over the existing
// neighbours of w (u - u_nb); rhs is not read for A u. u and rhs are whole arrays, b and out the
// row's own (out need not be part of an array shaped like u). Each form keeps its own order of
// operations. Always inlined, so that it compiles inside each caller's vector clones.
template <bool kResidual>
[[gnu::always_inline]] inline void stencil_row(const float* u, const float* rhs, float* __restrict out,
                                               const float* __restrict b, const RowNeighbours& r, float cx, int nx) {
  const float* __restrict f = kResidual ? rhs + r.row : nullptr;
  const float *__restrict u0 = u + r.row, *__restrict uym = u + r.ym, *__restrict uyp = u + r.yp,
              *__restrict uzm = u + r.zm, *__restrict uzp = u + r.zp;
  const float wym = r.wym, wyp = r.wyp, wzm = r.wzm, wzp = r.wzp, side = wym + wyp + wzm + wzp;
  auto at = [&](int i, float lap_x, float wx) {
    if constexpr (kResidual)
      return f[i] + lap_x + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] - (side + wx + b[i]) * u0[i];
    else
      return (side + wx + b[i]) * u0[i] - lap_x - wym * uym[i] - wyp * uyp[i] - wzm * uzm[i] - wzp * uzp[i];
  };
  if (nx == 1) {
    out[0] = at(0, 0.f, 0.f);
    return;
  }
  out[0] = at(0, cx * u0[1], cx);
  const float diag = side + 2.f * cx;  // spelled out: a lambda would not inline into the AVX2 clone
  for (int i = 1; i < nx - 1; ++i) {
    if constexpr (kResidual)
      out[i] = f[i] + cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] -
               (diag + b[i]) * u0[i];
    else
      out[i] = (diag + b[i]) * u0[i] - cx * (u0[i - 1] + u0[i + 1]) - wym * uym[i] - wyp * uyp[i] - wzm * uzm[i] -
               wzp * uzp[i];
  }
  out[nx - 1] = at(nx - 1, cx * u0[nx - 2], cx);
}

// out = rhs - A u on one row (out: the row's residual).
DSNAKE_VECTOR_CLONES
void residual_row(const float* u, const float* rhs, float* out, const float* __restrict b, const RowNeighbours& r,
                  float cx, int nx) {
  stencil_row<true>(u, rhs, out, b, r, cx, nx);
}

// out = A u on one row (the product PCG needs; out: the row's product).
DSNAKE_VECTOR_CLONES
void apply_row(const float* u, float* out, const float* __restrict b, const RowNeighbours& r, float cx, int nx) {
  stencil_row<false>(u, nullptr, out, b, r, cx, nx);
}

}  // namespace

namespace gvf_detail {

// `sweeps` Gauss-Seidel sweeps in two colours, `first` then the other (voxels with
// (x + y + z) % 2 == colour), over all fields, in one pass over memory. Half-sweep h (colour
// first + h) follows half-sweep h - 1 with a lag of one plane (2D: one row): at step yz the pass
// does half-sweep h on row yz - h lag, once all that row's neighbours have half-sweep h - 1 and
// while they are still in cache. A thread runs half-sweep h in the pass on the rows of its block
// at least h lags from the block's ends; the rest (the skirts, which read the neighbouring
// block) follow in rounds h = 1, 2, ... after barriers. A row's update reads only the other
// colour of its neighbours, and that colour is at the state of half-sweep h - 1 whenever it is
// read, so the result equals the half-sweeps run one after the other, whatever the thread count.
// With zero_start, v is taken as 0 on entry (not read): the first half-sweep writes rhs / A_ii on
// its colour and 0 on the other, as a sweep from a zeroed v would.
void smooth_sweeps(Level& L, const Coupling& c, int first, int sweeps, bool zero_start) {
  const int K = int(L.v.size()), H = 2 * sweeps;
  const int64_t rows = int64_t(L.ny) * L.nz;
  const int64_t lag = L.nz > 1 ? L.ny : 1;  // rows between a row and its farthest neighbour
  auto update = [&](int64_t yz, int h) {
    const int y = int(yz % L.ny), z = int(yz / L.ny);
    const RowNeighbours r = row_neighbours(L, c, y, z);
    const int parity = (first + h + y + z) & 1;
    for (int k = 0; k < K; ++k) {
      if (zero_start && h == 0) {
        start_row(L.v[k].data() + r.row, L.rhs[k].data() + r.row, L.b.data() + r.row, r.wym + r.wyp + r.wzm + r.wzp,
                  c.cx, L.nx, parity);
      } else {
        smooth_row(L.v[k].data(), L.rhs[k].data(), L.b.data() + r.row, r, c.cx, L.nx, parity);
      }
    }
  };
#pragma omp parallel if(L.size() >= kParallelMin)
  {
    const int t = omp_get_thread_num(), T = omp_get_num_threads();
    const int64_t begin = rows * t / T, end = rows * (t + 1) / T;
    auto in_pass = [&](int64_t yz, int h) { return yz >= begin + h * lag && yz < end - h * lag; };
    for (int64_t step = begin; step < end + (H - 1) * lag; ++step)
      for (int h = 0; h < H; ++h) {
        const int64_t yz = step - h * lag;
        if (yz >= begin && yz < end && in_pass(yz, h)) update(yz, h);
      }
    for (int h = 1; h < H; ++h) {
#pragma omp barrier
      for (int64_t yz = begin; yz < end; ++yz)
        if (!in_pass(yz, h)) update(yz, h);
    }
  }
}

}  // namespace gvf_detail

namespace {

// Dot product in fixed chunks (8 interleaved lanes each), summed in chunk order: vectorised and
// independent of the thread count.
DSNAKE_VECTOR_CLONES
double dot_chunk(const float* __restrict a, const float* __restrict b, int64_t n) {
  float lanes[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int64_t i = 0;
  for (; i + 8 <= n; i += 8)
    for (int j = 0; j < 8; ++j) lanes[j] += a[i + j] * b[i + j];
  double s = 0;
  for (int j = 0; j < 8; ++j) s += lanes[j];
  for (; i < n; ++i) s += double(a[i]) * b[i];
  return s;
}

// out = rhs - A v for all fields (out[k] of the level's size). With `norms`, also returns the sums
// of squares of out and of rhs (per row, then in row order: independent of the thread count).
std::pair<double, double> residual(const Level& L, const Coupling& c, std::vector<std::vector<float>>& out,
                                   bool norms = false) {
  const int nx = L.nx, K = int(L.v.size());
  const int64_t rows = int64_t(L.ny) * L.nz;
  std::vector<double> rr(norms ? rows : 0), bb(norms ? rows : 0);
#pragma omp parallel for schedule(static) if(L.size() >= kParallelMin)
  for (int64_t yz = 0; yz < rows; ++yz) {
    const RowNeighbours r = row_neighbours(L, c, int(yz % L.ny), int(yz / L.ny));
    double s2 = 0, b2 = 0;
    for (int k = 0; k < K; ++k) {
      residual_row(L.v[k].data(), L.rhs[k].data(), out[k].data() + r.row, L.b.data() + r.row, r, c.cx, nx);
      if (norms) {
        const float* res = out[k].data() + r.row;
        const float* rhs = L.rhs[k].data() + r.row;
        s2 += dot_chunk(res, res, nx);
        b2 += dot_chunk(rhs, rhs, nx);
      }
    }
    if (norms) rr[yz] = s2, bb[yz] = b2;
  }
  double s = 0, t = 0;
  for (size_t yz = 0; yz < rr.size(); ++yz) s += rr[yz], t += bb[yz];
  return {s, t};
}

}  // namespace

namespace gvf_detail {

void residual_rows(Level& L, const Coupling& c) { residual(L, c, L.res); }

}  // namespace gvf_detail

namespace {

// Grid transfer along one axis. An even axis is coarsened cell-centred (coarse cell I = fine
// cells 2I, 2I + 1, at I - 1/4 and I + 1/4 in coarse units); an odd axis vertex-centred (coarse
// node I = fine node 2I, the ends stay the ends). Either way the coarse grid is uniform with
// twice the spacing and covers the same extent. Prolongation P is linear interpolation; the
// residual is restricted with R = P^T / factor, so that the cycle is a symmetric operator
// (a valid preconditioner for conjugate gradients); b is restricted with R normalised to an
// average. Factor 1: identity.
AxisTransfer axis_transfer(int n_fine, int n_coarse, int factor) {
  AxisTransfer t;
  t.near.resize(n_fine), t.far.resize(n_fine), t.w_near.resize(n_fine);
  for (int i = 0; i < n_fine; ++i) {
    const int I = factor == 1 ? i : i / 2;
    t.near[i] = I;
    if (factor == 1) {
      t.far[i] = i, t.w_near[i] = 1.f;
    } else if (n_fine % 2 == 0) {  // cell-centred
      t.far[i] = (i % 2 == 0) ? std::max(I - 1, 0) : std::min(I + 1, n_coarse - 1);
      t.w_near[i] = 0.75f;
    } else {  // vertex-centred
      t.far[i] = std::min(I + 1, n_coarse - 1);
      t.w_near[i] = (i % 2 == 0) ? 1.f : 0.5f;
    }
  }
  // R = P^T / factor, merging repeated (clamped) entries.
  std::vector<std::map<int, float>> rows(n_coarse);
  for (int i = 0; i < n_fine; ++i) {
    rows[t.near[i]][i] += t.w_near[i] / factor;
    if (t.w_near[i] < 1.f) rows[t.far[i]][i] += (1.f - t.w_near[i]) / factor;
  }
  t.transpose.resize(n_coarse), t.average.resize(n_coarse);
  for (int I = 0; I < n_coarse; ++I) {
    float sum = 0;
    for (const auto& [i, w] : rows[I]) t.transpose[I].push_back({i, w}), sum += w;
    for (const auto& [i, w] : rows[I]) t.average[I].push_back({i, w / sum});
  }
  return t;
}

// Coarse cell count along an axis for the transfers above.
int coarse_size(int n, int factor) { return factor == 1 ? n : (n % 2 == 0 ? n / 2 : (n + 1) / 2); }

}  // namespace

namespace gvf_detail {

Transfer transfer(const Level& F, const Level& C) {
  return {axis_transfer(F.nx, C.nx, F.factor[0]), axis_transfer(F.ny, C.ny, F.factor[1]),
          axis_transfer(F.nz, C.nz, F.factor[2])};
}

// out = R row along x for a factor-2 axis (R = P^T / 2 of axis_transfer's weights), from the
// fine row extended by one value at each end (ext[i + 1] = row[i]; the ends repeat the row's
// end values when cell-centred, 0 when vertex-centred): contiguous loads, no scatter.
// Cell-centred: out[I] = 3/8 (row[2I] + row[2I + 1]) + 1/8 (row[2I - 1] + row[2I + 2]);
// vertex-centred: out[I] = 1/2 row[2I] + 1/4 (row[2I - 1] + row[2I + 1]).
DSNAKE_VECTOR_CLONES
void restrict_row_x2(float* __restrict out, const float* __restrict ext, int n_fine, int n_coarse) {
  if (n_fine % 2 == 0) {
    for (int I = 0; I < n_coarse; ++I)
      out[I] = 0.375f * (ext[2 * I + 1] + ext[2 * I + 2]) + 0.125f * (ext[2 * I] + ext[2 * I + 3]);
  } else {
    for (int I = 0; I < n_coarse; ++I) out[I] = 0.5f * ext[2 * I + 1] + 0.25f * (ext[2 * I] + ext[2 * I + 2]);
  }
}

}  // namespace gvf_detail

namespace {

// out = the x part of the restriction of `row` (a fine row already combined along y and z):
// R = P^T / factor (average = false) or its normalised average. ext: scratch of nx + 2 floats.
void restrict_x(const Level& F, const Level& C, const Transfer& t, bool average, std::vector<float>& row,
                std::vector<float>& ext, float* out) {
  if (!average && F.factor[0] == 2) {
    const bool cell = F.nx % 2 == 0;
    std::copy(row.begin(), row.end(), ext.begin() + 1);
    ext[0] = cell ? row[0] : 0.f, ext[F.nx + 1] = cell ? row[F.nx - 1] : 0.f;
    restrict_row_x2(out, ext.data(), F.nx, C.nx);
  } else if (!average) {  // R = P^T / factor along x: scatter each fine value (in x order)
    const float inv = 1.f / F.factor[0];
    std::fill_n(out, C.nx, 0.f);
    for (int x = 0; x < F.nx; ++x) {
      const float w = t.x.w_near[x] * inv;
      out[t.x.near[x]] += w * row[x];
      out[t.x.far[x]] += (inv - w) * row[x];
    }
  } else {
    for (int x = 0; x < C.nx; ++x) {
      float s = 0;
      for (const auto& [fx, wx] : t.x.average[x]) s += wx * row[fx];
      out[x] = s;
    }
  }
}

// row += w * src over nx floats (the y/z part of a restriction).
void add_scaled(std::vector<float>& row, float w, const float* __restrict src) {
  float* __restrict dst = row.data();
  for (size_t x = 0; x < row.size(); ++x) dst[x] += w * src[x];
}

}  // namespace

namespace gvf_detail {

// coarse = R fine (separable; R = P^T / factor or its normalised average): the y/z weights combine fine rows into one
// (contiguous, vectorised), then the x weights pick from it.
void restrict_to(const Level& F, const Level& C, const Transfer& t, bool average, const float* fine, float* coarse) {
  auto weights = [&](const AxisTransfer& a, int I) -> const std::vector<std::pair<int, float>>& {
    return average ? a.average[I] : a.transpose[I];
  };
#pragma omp parallel if(F.size() >= kParallelMin)
  {
    std::vector<float> row(F.nx), ext(F.nx + 2);
#pragma omp for schedule(static)
    for (int64_t zy = 0; zy < int64_t(C.nz) * C.ny; ++zy) {
      const int z = int(zy / C.ny), y = int(zy % C.ny);
      std::fill(row.begin(), row.end(), 0.f);
      for (const auto& [fz, wz] : weights(t.z, z))
        for (const auto& [fy, wy] : weights(t.y, y)) add_scaled(row, wz * wy, fine + (int64_t(fz) * F.ny + fy) * F.nx);
      restrict_x(F, C, t, average, row, ext, coarse + (int64_t(z) * C.ny + y) * C.nx);
    }
  }
}

// coarse = R (rhs - A v) of field k, as residual_rows then restrict_to(average = false) would give
// it bit for bit, but without a residual array of the fine level's size (4 bytes per
// voxel at the finest level). The fine grid is cut into slabs along its outer axis (z planes; on
// a single plane, rows). Each thread takes a run of coarse slabs in order; a coarse slab reads at
// most four consecutive fine slabs (cell-centred: 2I - 1 .. 2I + 2), so the thread keeps the fine
// residual slabs in a ring of four and computes each once (twice at the ends of its run). Every
// coarse row is summed in restrict_to's order, so the result does not depend on the thread count.
void restrict_residual(const Level& F, const Coupling& c, const Level& C, const Transfer& t, int k, float* coarse) {
  const bool planes = F.nz > 1;
  const AxisTransfer& outer = planes ? t.z : t.y;
  const int coarse_slabs = planes ? C.nz : C.ny, rows_per_slab = planes ? F.ny : 1;
  const int coarse_rows_per_slab = planes ? C.ny : 1;
  const int64_t slab = int64_t(rows_per_slab) * F.nx;
  static const std::vector<std::pair<int, float>> kOne = {{0, 1.f}};
#pragma omp parallel if(F.size() >= kParallelMin)
  {
    thread_local std::vector<float> ring;  // kept across calls: no page faults per cycle
    if (ring.size() < size_t(4 * slab)) ring.resize(4 * slab);
    int tag[4] = {-1, -1, -1, -1};
    std::vector<float> row(F.nx), ext(F.nx + 2);
    const int T = omp_get_num_threads(), th = omp_get_thread_num();
    const int begin = int(int64_t(coarse_slabs) * th / T), end = int(int64_t(coarse_slabs) * (th + 1) / T);
    auto fine_slab = [&](int s) -> const float* {
      float* dst = ring.data() + (s % 4) * slab;
      if (tag[s % 4] != s) {
        for (int q = 0; q < rows_per_slab; ++q) {
          const int y = planes ? q : s, z = planes ? s : 0;
          const RowNeighbours rn = row_neighbours(F, c, y, z);
          residual_row(F.v[k].data(), F.rhs[k].data(), dst + int64_t(q) * F.nx, F.b.data() + rn.row, rn, c.cx, F.nx);
        }
        tag[s % 4] = s;
      }
      return dst;
    };
    for (int S = begin; S < end; ++S) {
      const float* slabs[4];
      const auto& outer_w = outer.transpose[S];
      for (size_t j = 0; j < outer_w.size(); ++j) slabs[j] = fine_slab(outer_w[j].first);
      for (int Q = 0; Q < coarse_rows_per_slab; ++Q) {
        std::fill(row.begin(), row.end(), 0.f);
        const auto& inner_w = planes ? t.y.transpose[Q] : kOne;
        for (size_t j = 0; j < outer_w.size(); ++j)
          for (const auto& [q, wq] : inner_w) add_scaled(row, outer_w[j].second * wq, slabs[j] + int64_t(q) * F.nx);
        const int64_t coarse_row = planes ? int64_t(S) * C.ny + Q : S;
        restrict_x(F, C, t, false, row, ext, coarse + coarse_row * C.nx);
      }
    }
  }
}

}  // namespace gvf_detail

namespace gvf_detail {

// out += P row along x for a factor-2 axis (axis_transfer's weights), from the coarse row
// extended by one clamped value at each end (ext[I + 1] = row[I]): contiguous loads instead of
// the index tables. Cell-centred (even fine size): fine 2I = 3/4 row[I] + 1/4 row[I - 1],
// 2I + 1 = 3/4 row[I] + 1/4 row[I + 1]; vertex-centred (odd): 2I = row[I], 2I + 1 = the mean.
DSNAKE_VECTOR_CLONES
void prolongate_row_x2(float* __restrict out, const float* __restrict ext, int n_fine, int n_coarse) {
  if (n_fine % 2 == 0) {
    for (int I = 0; I < n_coarse; ++I) {
      out[2 * I] += 0.75f * ext[I + 1] + 0.25f * ext[I];
      out[2 * I + 1] += 0.75f * ext[I + 1] + 0.25f * ext[I + 2];
    }
  } else {
    for (int I = 0; I + 1 < n_coarse; ++I) {
      out[2 * I] += ext[I + 1];
      out[2 * I + 1] += 0.5f * ext[I + 1] + 0.5f * ext[I + 2];
    }
    out[n_fine - 1] += ext[n_coarse];
  }
}

}  // namespace gvf_detail

namespace {

// fine += P coarse (separable linear interpolation): y/z first on a coarse row, then x.
void prolongate_add(const Level& F, const Level& C, const Transfer& t, const float* coarse, float* fine) {
  const AxisTransfer &ax = t.x, &ay = t.y, &az = t.z;
#pragma omp parallel if(F.size() >= kParallelMin)
  {
    std::vector<float> row(C.nx), ext(C.nx + 2);
#pragma omp for schedule(static)
    for (int64_t zy = 0; zy < int64_t(F.nz) * F.ny; ++zy) {
      const int z = int(zy / F.ny), y = int(zy % F.ny);
      const int zs[2] = {az.near[z], az.far[z]}, ys[2] = {ay.near[y], ay.far[y]};
      const float wz[2] = {az.w_near[z], 1.f - az.w_near[z]}, wy[2] = {ay.w_near[y], 1.f - ay.w_near[y]};
      std::fill(row.begin(), row.end(), 0.f);
      for (int p = 0; p < 2; ++p)
        for (int q = 0; q < 2; ++q) {
          const float w = wz[p] * wy[q];
          if (w == 0.f) continue;
          const float* __restrict src = coarse + (int64_t(zs[p]) * C.ny + ys[q]) * C.nx;
          float* __restrict dst = row.data();
          for (int x = 0; x < C.nx; ++x) dst[x] += w * src[x];
        }
      float* out = fine + (int64_t(z) * F.ny + y) * F.nx;
      if (F.factor[0] == 2) {
        std::copy(row.begin(), row.end(), ext.begin() + 1);
        ext[0] = row[0], ext[C.nx + 1] = row[C.nx - 1];
        prolongate_row_x2(out, ext.data(), F.nx, C.nx);
      } else {
        for (int x = 0; x < F.nx; ++x) out[x] += ax.w_near[x] * row[ax.near[x]] + (1.f - ax.w_near[x]) * row[ax.far[x]];
      }
    }
  }
}

constexpr int64_t kCoarsestVoxels = 400;  // dense direct solve below this size
constexpr int kPreSmooth = 2, kPostSmooth = 2;  // red-black sweeps per cycle and level

// The multigrid hierarchy for one solve: levels, and the coarsest grid's factorisation.
class Multigrid {
 public:
  // The hierarchy for grids shaped like finest_shape and K fields, with weights b.
  Multigrid(const Level& finest_shape, std::vector<float> b, int K, double mu) : mu_(mu), K_(K) {
    levels_.push_back(finest_shape);
    for (;;) {
      Level& F = levels_.back();
      alloc(F, K, levels_.size() == 1);
      if (F.size() <= kCoarsestVoxels) break;
      const int n[3] = {F.nx, F.ny, F.nz};
      const double h_min = std::min({n[0] > 1 ? F.h[0] : 1e300, n[1] > 1 ? F.h[1] : 1e300, n[2] > 1 ? F.h[2] : 1e300});
      Level C;
      bool any = false;
      int cn[3];
      for (int a = 0; a < 3; ++a) {
        // Semi-coarsening: only the axes whose spacing is within 1.5x of the finest.
        F.factor[a] = (n[a] > 1 && F.h[a] < 1.5 * h_min) ? 2 : 1;
        any |= F.factor[a] == 2;
        cn[a] = coarse_size(n[a], F.factor[a]);
        C.h[a] = F.h[a] * F.factor[a];
      }
      if (!any) break;
      C.nx = cn[0], C.ny = cn[1], C.nz = cn[2];
      transfers_.push_back(transfer(F, C));
      levels_.push_back(std::move(C));
    }
    set_weights(std::move(b));
  }

  // True if this hierarchy serves grids shaped like `shape` with K fields and this mu.
  bool fits(const Level& shape, int K, double mu) const {
    const Level& F = levels_[0];
    return F.nx == shape.nx && F.ny == shape.ny && F.nz == shape.nz && F.h[0] == shape.h[0] &&
           F.h[1] == shape.h[1] && F.h[2] == shape.h[2] && K == K_ && mu == mu_;
  }

  // New weights b on the same grids (no allocation): b on every level (averaged down) and the
  // coarsest factorisation, exactly as a new hierarchy would compute them.
  void set_weights(std::vector<float> b) {
    levels_[0].b = std::move(b);
    for (size_t l = 0; l < levels_.size(); ++l) {
      Level& F = levels_[l];
      if (l + 1 < levels_.size()) {
        Level& C = levels_[l + 1];
        C.b.resize(C.size());
        restrict_to(F, C, transfers_[l], true, F.b.data(), C.b.data());
      }
    }
    factor_coarsest();
  }

  std::vector<Level>& levels() { return levels_; }

  // One cycle from level l: pre-smoothing (colours 0, 1), the coarse-grid correction, post-
  // smoothing (colours 1, 0, the adjoint order, so that the cycle is a symmetric operator). With
  // zero_start the initial guess is 0: v is overwritten, not read (the first smoothing half-sweep
  // starts from 0 without clearing v); otherwise the cycle improves v. The coarse grid is
  // visited twice (a W-cycle) where it halves all three axes (about an eighth of this level's
  // voxels) and is not the coarsest (whose exact solve a second visit would repeat). The
  // rediscretised coarse grids see the image's sharp weights b (edges,
  // DDGVF's masks) only in average; with V-cycles PCG removed what they missed at about 0.4
  // per iteration (lung DDGVF: 7 iterations to 1e-4, 4 with W-cycles), and the extra visits
  // cost 1/4 + 1/16 + ... of the finest level's pass (BM_DdgvfField3d, 1 thread: 2.89 s with
  // W-cycles, 3.46 s with V-cycles). Where a level shrinks only 4 times (2D, semi-coarsening)
  // they would cost as much as the finest level, on grids too small for two threads: 2D GVF
  // would take 4 iterations instead of 6 but 40 ms instead of 36 on 1 thread and 31 instead of
  // 21 on 2 (BM_GvfMultigridConverged2d), so those levels keep V-cycles.
  void cycle(size_t l, bool zero_start = true) {
    Level& L = levels_[l];
    const Coupling c = coupling(L, mu_);
    if (l + 1 == levels_.size()) {
      solve_coarsest();
      return;
    }
    smooth_sweeps(L, c, 0, kPreSmooth, zero_start);
    Level& C = levels_[l + 1];
    for (size_t k = 0; k < L.v.size(); ++k) restrict_residual(L, c, C, transfers_[l], int(k), C.rhs[k].data());
    const bool all_axes = L.nz > 1 && L.factor[0] == 2 && L.factor[1] == 2 && L.factor[2] == 2;
    const int visits = (l + 2 < levels_.size() && all_axes) ? 2 : 1;
    for (int visit = 0; visit < visits; ++visit) cycle(l + 1, visit == 0);
    for (size_t k = 0; k < L.v.size(); ++k) prolongate_add(L, C, transfers_[l], C.v[k].data(), L.v[k].data());
    smooth_sweeps(L, c, 1, kPostSmooth, false);
  }

 private:
  // v and rhs per field; no residual array (restrict_residual). The finest level's rhs is left
  // empty: the caller lends it its own right-hand side (solve_one_field's r).
  static void alloc(Level& L, int K, bool finest) {
    L.v.assign(K, std::vector<float>(L.size()));
    L.rhs.assign(K, std::vector<float>(finest ? 0 : L.size()));
  }

  // Dense A on the coarsest grid, LDL^T-factorised once (A is shared by all fields).
  void factor_coarsest() {
    Level& L = levels_.back();
    const Coupling c = coupling(L, mu_);
    const int64_t n = L.size();
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
    for (int z = 0; z < L.nz; ++z)
      for (int y = 0; y < L.ny; ++y)
        for (int x = 0; x < L.nx; ++x) {
          const int64_t l = (int64_t(z) * L.ny + y) * L.nx + x;
          A(l, l) += L.b[l];
          auto link = [&](int64_t m, double w) { A(l, l) += w, A(l, m) -= w; };
          if (x > 0) link(l - 1, c.cx);
          if (x < L.nx - 1) link(l + 1, c.cx);
          if (y > 0) link(l - L.nx, c.cy);
          if (y < L.ny - 1) link(l + L.nx, c.cy);
          if (z > 0) link(l - int64_t(L.nx) * L.ny, c.cz);
          if (z < L.nz - 1) link(l + int64_t(L.nx) * L.ny, c.cz);
        }
    // A tiny regularisation keeps the pure-diffusion (b = 0) null space harmless.
    const double eps = 1e-12 * std::max(1.0, A.diagonal().maxCoeff());
    A.diagonal().array() += eps;
    coarsest_.compute(A);
  }

  void solve_coarsest() {
    Level& L = levels_.back();
    for (size_t k = 0; k < L.v.size(); ++k) {
      Eigen::VectorXd r(L.size());
      for (int64_t l = 0; l < L.size(); ++l) r[l] = L.rhs[k][l];
      const Eigen::VectorXd x = coarsest_.solve(r);
      for (int64_t l = 0; l < L.size(); ++l) L.v[k][l] = float(x[l]);
    }
  }

  double mu_;
  int K_;
  std::vector<Level> levels_;
  std::vector<Transfer> transfers_;  // from level l to l + 1
  Eigen::LDLT<Eigen::MatrixXd> coarsest_;
};

}  // namespace

// A caller's workspace: the last multigrid hierarchy and the PCG vectors.
struct GvfWorkspace::Impl {
  std::unique_ptr<Multigrid> multigrid;
  std::vector<std::vector<float>> r, p;
};
GvfWorkspace::GvfWorkspace() : impl_(std::make_unique<Impl>()) {}
GvfWorkspace::~GvfWorkspace() = default;
std::vector<float> GvfWorkspace::take_weights() {
  if (!impl_->multigrid) return {};
  return std::exchange(impl_->multigrid->levels()[0].b, {});
}

namespace {

double dot(const std::vector<float>& a, const std::vector<float>& b) {
  constexpr int64_t kChunk = 4096;
  const int64_t n = int64_t(a.size()), chunks = (n + kChunk - 1) / kChunk;
  std::vector<double> part(chunks);
#pragma omp parallel for schedule(static) if(n >= kParallelMin)
  for (int64_t c = 0; c < chunks; ++c)
    part[c] = dot_chunk(a.data() + c * kChunk, b.data() + c * kChunk, std::min(kChunk, n - c * kChunk));
  double s = 0;
  for (double x : part) s += x;
  return s;
}

// x += a p, r -= a ap, and returns |r|^2 of the updated r: one pass instead of two, with the
// chunks and chunk sums of dot() (so the same value as dot(r, r) after the update).
double update_and_norm(float* __restrict x, float* __restrict r, const float* __restrict p,
                       const float* __restrict ap, float a, int64_t n) {
  constexpr int64_t kChunk = 4096;
  const int64_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<double> part(chunks);
#pragma omp parallel for schedule(static) if(n >= kParallelMin)
  for (int64_t c = 0; c < chunks; ++c) {
    const int64_t begin = c * kChunk, end = std::min(n, begin + kChunk);
    for (int64_t l = begin; l < end; ++l) x[l] += a * p[l], r[l] -= a * ap[l];
    part[c] = dot_chunk(r + begin, r + begin, end - begin);
  }
  double s = 0;
  for (double v : part) s += v;
  return s;
}

// Conjugate gradients on A x = b c for one field, preconditioned by one multigrid W-cycle per
// iteration (a symmetric positive definite preconditioner: symmetric smoothing, R = P^T / factor,
// exact coarsest solve). Cycles alone stall where the coarse grids see the image border
// differently from the fine one (odd sizes, masked DDGVF weights); CG removes those few slow
// modes. c may be x itself (GVF's initial guess is its source): c is read only before x changes.
// The finest level holds three arrays besides x, b and 1 / A_ii: r (lent to the
// cycle as its right-hand side), p, and the level's v, which holds z = M r and then A p (z is
// spent once p = z + beta p). b c lives in p's storage until the first residual is known. The
// workspace keeps r and p for the next field. Returns the iterations and |r|^2, |b c|^2.
struct FieldSolve {
  int iterations = 0;
  double r2 = 0, f2 = 0;
};
FieldSolve solve_one_field(Multigrid& mg, const std::vector<float>& c, std::vector<float>& x,
                           const GvfSolveOptions& o, GvfWorkspace::Impl& ws) {
  Level& L = mg.levels()[0];
  const std::vector<float>& b = L.b;
  const int64_t n = L.size(), rows = int64_t(L.ny) * L.nz;
  const Coupling cp = coupling(L, o.mu);
  ws.r.resize(1), ws.p.resize(1);
  std::vector<float>& r = ws.r[0];
  std::vector<float>& p = ws.p[0];
  r.resize(n), p.resize(n);  // allocated by the first field, reused by the others
  L.v[0] = x;
  L.rhs[0].swap(p);  // b c, in p's storage
#pragma omp parallel for schedule(static) if(n >= kParallelMin)
  for (int64_t l = 0; l < n; ++l) L.rhs[0][l] = b[l] * c[l];
  FieldSolve st;
  std::tie(st.r2, st.f2) = residual(L, cp, ws.r, true);  // r = b c - A x
  L.rhs[0].swap(p);  // b c is not needed again
  auto converged = [&] {
    const double relative = st.f2 > 0 ? std::sqrt(st.r2 / st.f2) : (st.r2 > 0 ? 1.0 : 0.0);
    return o.tolerance > 0 && relative <= o.tolerance;
  };
  // z = M r: a cycle from zero with r as right-hand side; z is left in L.v.
  auto precondition = [&] {
    L.rhs[0].swap(r);  // the cycle takes v as 0
    mg.cycle(0);
    L.rhs[0].swap(r);
  };
  const int max_it = o.iterations > 0 ? o.iterations : 100;
  if (converged()) return st;
  precondition();
  std::vector<double> row_pap(rows);
  p = L.v[0];
  double rz = dot(r, L.v[0]);
  std::vector<float>& ap = L.v[0];  // z is spent once p is updated
  while (st.iterations < max_it) {
    // ap = A p, then x += alpha p, r -= alpha ap.
    // With p.ap per row while the row is in cache (summed in row order: thread-independent).
#pragma omp parallel for schedule(static) if(n >= kParallelMin)
    for (int64_t yz = 0; yz < rows; ++yz) {
      const RowNeighbours rn = row_neighbours(L, cp, int(yz % L.ny), int(yz / L.ny));
      apply_row(p.data(), ap.data() + rn.row, b.data() + rn.row, rn, cp.cx, L.nx);
      row_pap[yz] = dot_chunk(p.data() + rn.row, ap.data() + rn.row, L.nx);
    }
    double pap = 0;
    for (int64_t yz = 0; yz < rows; ++yz) pap += row_pap[yz];
    const float alpha = float(pap > 0 ? rz / pap : 0.0);
    st.r2 = update_and_norm(x.data(), r.data(), p.data(), ap.data(), alpha, n);
    ++st.iterations;
    if (converged() || st.iterations == max_it) break;
    precondition();
    const double rz_new = dot(r, L.v[0]);
    const float beta = rz > 0 ? float(rz_new / rz) : 0.f;
    rz = rz_new;
    float* __restrict pk = p.data();
    const float* __restrict zk = L.v[0].data();
#pragma omp parallel for schedule(static) if(n >= kParallelMin)
    for (int64_t l = 0; l < n; ++l) pk[l] = zk[l] + beta * pk[l];
  }
  return st;
}

// The K fields one after another on one hierarchy (built for a single field), each with its own
// stopping test |r_k| <= tolerance |b c_k|, so that the memory is that of one field (K
// fields sharing the cycles' passes would hold 5 K full-grid arrays). Every field meeting the test
// implies the joint one, |r| <= tolerance |b c|; the stats give the most iterations any field
// took and the joint relative residual.
GvfSolveStats solve_multigrid_pcg(Level shape, std::vector<float>&& b,
                                  const std::vector<const std::vector<float>*>& c,
                                  const std::vector<std::vector<float>*>& x, const GvfSolveOptions& o,
                                  GvfWorkspace::Impl& ws) {
  if (ws.multigrid && ws.multigrid->fits(shape, 1, o.mu)) {
    ws.multigrid->set_weights(std::move(b));
  } else {
    ws.multigrid = std::make_unique<Multigrid>(shape, std::move(b), 1, o.mu);
  }
  GvfSolveStats st;
  double r2 = 0, f2 = 0;
  for (size_t k = 0; k < x.size(); ++k) {
    const FieldSolve one = solve_one_field(*ws.multigrid, *c[k], *x[k], o, ws);
    st.iterations = std::max(st.iterations, one.iterations);
    r2 += one.r2, f2 += one.f2;
  }
  st.relative_residual = f2 > 0 ? std::sqrt(r2 / f2) : (r2 > 0 ? 1.0 : 0.0);
  return st;
}

}  // namespace

template <int D>
GvfSolveStats solve_gvf(const Grid<D>& grid, std::vector<float> b,
                        const std::vector<const std::vector<float>*>& c, const std::vector<std::vector<float>*>& v,
                        const GvfSolveOptions& o, GvfWorkspace* workspace) {
  DSNAKE_ASSERT(o.mu > 0, "GVF: mu > 0");
  DSNAKE_ASSERT(c.size() == v.size(), "GVF: one source per field");
  const int64_t n = grid.num_voxels();
  DSNAKE_ASSERT(int64_t(b.size()) == n, "GVF: b on the grid");
  Level shape = level_of(grid);
  if (o.solver == GvfSolver::kExplicit) {
    // |b c|^2, the scale of the relative residual (the multigrid solver computes its own).
    // In 8 partial sums, fixed order (vectorised, the same on any machine and thread count).
    double part[8] = {}, rhs_norm2 = 0;
    for (size_t k = 0; k < c.size(); ++k) {
      const float* ck = c[k]->data();
      int64_t l = 0;
      for (; l + 8 <= n; l += 8)
        for (int j = 0; j < 8; ++j) {
          const double r = double(b[l + j]) * ck[l + j];
          part[j] += r * r;
        }
      for (; l < n; ++l) {
        const double r = double(b[l]) * ck[l];
        rhs_norm2 += r * r;
      }
    }
    for (double p : part) rhs_norm2 += p;
    return solve_explicit(shape, b, c, v, o, rhs_norm2);
  }
  DSNAKE_ASSERT(o.solver == GvfSolver::kMultigrid, "GVF: solver is explicit or multigrid");
  if (workspace) return solve_multigrid_pcg(shape, std::move(b), c, v, o, workspace->impl());
  GvfWorkspace::Impl local;
  return solve_multigrid_pcg(shape, std::move(b), c, v, o, local);
}

template <int D>
double gvf_relative_residual(const Grid<D>& grid, const std::vector<float>& b,
                             const std::vector<const std::vector<float>*>& c,
                             const std::vector<const std::vector<float>*>& v, double mu) {
  Level L = level_of(grid);
  L.b = b;
  const int K = int(v.size());
  L.v.resize(K), L.rhs.resize(K), L.res.assign(K, std::vector<float>(L.size()));
  for (int k = 0; k < K; ++k) {
    L.v[k] = *v[k];
    L.rhs[k].resize(L.size());
    for (int64_t l = 0; l < L.size(); ++l) L.rhs[k][l] = b[l] * (*c[k])[l];
  }
  const auto [r2, f2] = residual(L, coupling(L, mu), L.res, true);
  return f2 > 0 ? std::sqrt(r2 / f2) : (r2 > 0 ? 1.0 : 0.0);
}

template <int D>
void check_explicit_step(const Grid<D>& grid, const GvfSolveOptions& options) {
  if (options.solver != GvfSolver::kExplicit || options.time_step <= 0) return;
  double lap_max = 0;
  for (int a = 0; a < D; ++a)
    if (grid.size[a] > 1) lap_max += 4.0 * options.mu / (grid.spacing[a] * grid.spacing[a]);
  if (lap_max > 0 && options.time_step >= 2.0 / lap_max)
    throw InputError("", "field.time_step",
                     "explicit GVF step " + std::to_string(options.time_step) + " is unstable on this grid: it must be < " +
                         std::to_string(2.0 / lap_max) + " (2 / (4 mu sum 1/h^2)), less the image's edge strength");
}

template void check_explicit_step(const Grid<2>&, const GvfSolveOptions&);
template void check_explicit_step(const Grid<3>&, const GvfSolveOptions&);
template GvfSolveStats solve_gvf(const Grid<2>&, std::vector<float>, const std::vector<const std::vector<float>*>&,
                                 const std::vector<std::vector<float>*>&, const GvfSolveOptions&, GvfWorkspace*);
template GvfSolveStats solve_gvf(const Grid<3>&, std::vector<float>, const std::vector<const std::vector<float>*>&,
                                 const std::vector<std::vector<float>*>&, const GvfSolveOptions&, GvfWorkspace*);
template double gvf_relative_residual(const Grid<2>&, const std::vector<float>&,
                                      const std::vector<const std::vector<float>*>&,
                                      const std::vector<const std::vector<float>*>&, double);
template double gvf_relative_residual(const Grid<3>&, const std::vector<float>&,
                                      const std::vector<const std::vector<float>*>&,
                                      const std::vector<const std::vector<float>*>&, double);

}  // namespace dsnake
