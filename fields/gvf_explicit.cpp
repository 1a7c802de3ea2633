// Xu & Prince's explicit GVF iteration (1998), the reference solver; see gvf_solver.h.
//
// Temporal blocking: one sweep of v_new = v + dt (mu Lap v - b (v - c)) reads and writes every
// array once, so a plain double-buffered loop is bound by memory bandwidth. Here T consecutive
// iterations run as a wavefront over planes (z-slices in 3D, rows in 2D): time level t computes
// plane p from planes p-1..p+1 of level t-1 while they are still in cache, so the arrays stream
// from memory once per T iterations. The grid is cut into tiles (y-ranges of the slices in 3D,
// ranges of rows in 2D) that a thread sweeps on its own: level t of a tile also computes the
// T - t rows or planes around it that level t+1 reads (overlapped tiling: a little redundant
// work, no synchronisation). The intermediate levels live in per-thread rings of three planes;
// a tile is swept one field at a time (the fields share only b), which keeps the rings small.
// Every voxel of every level is computed by the same row kernel from the same operands in the
// same order as the plain iteration (T = 1), so the results are bit-identical for every block
// depth, tile size and thread count.
#include "fields/gvf_grid.h"

#include "framework/errors.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <omp.h>

namespace dsnake::gvf_detail {

namespace {

// Wavefront shape, measured on 230 x 300 x 80 and 512^2 (see README): a block runs this many
// iterations (10 divides the residual-check interval, so tolerance runs keep full blocks); a 3D
// tile is about this many rows (y) of the slices.
constexpr int kDepth3d = 10;
constexpr int kDepth2d = 10;
constexpr int kTileRows3d = 72;

// The five input rows of a voxel row at one time level and their weights (a missing
// neighbour points at the row itself with weight 0: zero flux).
struct RowInputs {
  const float *u0, *uym, *uyp, *uzm, *uzp;
  float wym, wyp, wzm, wzp;
};

// One explicit step on a row of one field: out = u + dt (mu Lap u - b (u - c)); with `measure`,
// also acc += |mu Lap u - b (u - c)|^2 in index order (a scalar loop, so that the sum does not
// depend on vector width or threads). End voxels of the row have one x neighbour.
DSNAKE_VECTOR_CLONES
void explicit_row(const RowInputs& r, const float* __restrict src, const float* __restrict b, float* __restrict out,
                  float cx, float dt, int nx, bool measure, float& acc) {
  const float *__restrict u0 = r.u0, *__restrict uym = r.uym, *__restrict uyp = r.uyp, *__restrict uzm = r.uzm,
              *__restrict uzp = r.uzp;
  const float wym = r.wym, wyp = r.wyp, wzm = r.wzm, wzp = r.wzp;
  const float side = wym + wyp + wzm + wzp;
  auto residual_at = [&](int i, float lap_x, float wx) {
    return lap_x + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] - (side + wx + b[i]) * u0[i] +
           b[i] * src[i];
  };
  if (nx == 1) {
    const float e = residual_at(0, 0.f, 0.f);
    out[0] = u0[0] + dt * e;
    if (measure) acc += e * e;
    return;
  }
  const float e0 = residual_at(0, cx * u0[1], cx), e1 = residual_at(nx - 1, cx * u0[nx - 2], cx);
  out[0] = u0[0] + dt * e0;
  out[nx - 1] = u0[nx - 1] + dt * e1;
  // The interior loops spell the residual out: a lambda is compiled for the default target
  // and is not inlined into this function's AVX2 clone, which then does not vectorise. Without z
  // neighbours (2D) the two zero-weight terms are left out: adding 0 * u = +-0 changes no value.
  const float diag = side + 2.f * cx;
  const bool has_z = wzm != 0.f || wzp != 0.f;
  if (measure) acc += e0 * e0;
  if (measure && has_z) {
    for (int i = 1; i < nx - 1; ++i) {
      const float e = cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] -
                      (diag + b[i]) * u0[i] + b[i] * src[i];
      out[i] = u0[i] + dt * e;
      acc += e * e;
    }
  } else if (measure) {
    for (int i = 1; i < nx - 1; ++i) {
      const float e = cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] - (diag + b[i]) * u0[i] + b[i] * src[i];
      out[i] = u0[i] + dt * e;
      acc += e * e;
    }
  } else if (has_z) {
    for (int i = 1; i < nx - 1; ++i) {
      const float e = cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] -
                      (diag + b[i]) * u0[i] + b[i] * src[i];
      out[i] = u0[i] + dt * e;
    }
  } else {
    for (int i = 1; i < nx - 1; ++i) {
      const float e = cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] - (diag + b[i]) * u0[i] + b[i] * src[i];
      out[i] = u0[i] + dt * e;
    }
  }
  if (measure) acc += e1 * e1;
}

// A tile: planes [p0, p1) x rows [q0, q1) of the output level. Planes are z-slices in 3D
// (rows q = y within them) and rows in 2D (one "row" q = 0 per plane).
struct Tile {
  int p0, p1, q0, q1;
};

// The per-thread rings of a block of up to max_depth iterations over tiles of up to tile_rows
// rows; runs one field's wavefront over a tile. Row (p, q) of the grid is row p Q + q.
class Wavefront {
 public:
  // Sizes the rings (the only allocation): levels 1..max_depth-1, three planes each.
  Wavefront(const Level& L, int max_depth, int tile_rows, int threads)
      : nx_(L.nx), three_d_(L.nz > 1), P_(three_d_ ? L.nz : L.ny), Q_(three_d_ ? L.ny : 1),
        rows_(std::min(Q_, tile_rows + 2 * (max_depth - 1))),
        ring_size_(size_t(std::max(0, max_depth - 1)) * 3 * rows_ * nx_), rings_(threads) {
    for (auto& r : rings_) r.resize(ring_size_);
  }

  // Runs T iterations (1 <= T <= max_depth) of field k on the tile from v into next; with
  // `measure`, also row_acc[k rows + p Q + q] = the last iteration's squared residual of field k
  // on that row (summed in index order in float, as the plain loop does).
  void run_tile(const Tile& tile, int T, int k, const std::vector<std::vector<float>*>& v,
                std::vector<std::vector<float>>& next, const std::vector<const std::vector<float>*>& c,
                const std::vector<float>& b, const Coupling& cp, float dt, bool measure,
                std::vector<float>& row_acc, int thread) {
    float* ring = rings_[thread].data();
    const int base_p = tile.p0 - (T - 1), base_q = std::max(0, tile.q0 - (T - 1));
    // Plane p of field k at level t as an input (0: v) or output (T: next): its first stored row
    // and that row's index q (a ring plane starts at base_q, a grid plane at 0).
    struct PlaneRef {
      float* first;
      int q_first;
    };
    auto plane_at = [&](int t, int p) -> PlaneRef {
      if (t == 0) return {v[k]->data() + int64_t(p) * Q_ * nx_, 0};
      if (t == T) return {next[k].data() + int64_t(p) * Q_ * nx_, 0};
      return {ring + (int64_t(t - 1) * 3 + (p - base_p) % 3) * rows_ * nx_, base_q};
    };
    auto row_of = [&](const PlaneRef& plane, int q) { return plane.first + int64_t(q - plane.q_first) * nx_; };
    // Step s: level t computes plane base_p + s - (t - 1), after level t-1 computed the next one.
    for (int s = 0; s < tile.p1 - tile.p0 + 2 * (T - 1); ++s)
      for (int t = 1; t <= T; ++t) {
        const int p = base_p + s - (t - 1), grow = T - t;
        if (p < std::max(0, tile.p0 - grow) || p >= std::min(P_, tile.p1 + grow)) continue;
        const int q_lo = std::max(0, tile.q0 - grow), q_hi = std::min(Q_, tile.q1 + grow);
        // Neighbour planes (the plane itself, weight 0, at the border): z in 3D, y in 2D.
        const PlaneRef in = plane_at(t - 1, p), out = plane_at(t, p);
        const PlaneRef in_m = p > 0 ? plane_at(t - 1, p - 1) : in, in_p = p < P_ - 1 ? plane_at(t - 1, p + 1) : in;
        const float w_across = three_d_ ? cp.cz : cp.cy;
        const float wm = p > 0 ? w_across : 0.f, wp = p < P_ - 1 ? w_across : 0.f;
        const bool last = measure && t == T;
        for (int q = q_lo; q < q_hi; ++q) {
          const int64_t yz = int64_t(p) * Q_ + q;
          const float* u0 = row_of(in, q);
          RowInputs r{u0, u0, u0, u0, u0, 0, 0, 0, 0};
          if (three_d_) {  // y neighbours in the plane (rows are contiguous), z across planes
            if (q > 0) r.uym = u0 - nx_, r.wym = cp.cy;
            if (q < Q_ - 1) r.uyp = u0 + nx_, r.wyp = cp.cy;
            r.uzm = row_of(in_m, q), r.wzm = wm;
            r.uzp = row_of(in_p, q), r.wzp = wp;
          } else {  // 2D: y neighbours across planes (rows), no z
            r.uym = row_of(in_m, q), r.wym = wm;
            r.uyp = row_of(in_p, q), r.wyp = wp;
          }
          float acc = 0.f;
          explicit_row(r, c[k]->data() + yz * nx_, b.data() + yz * nx_, row_of(out, q), cp.cx, dt, nx_, last, acc);
          if (last) row_acc[k * int64_t(P_) * Q_ + yz] = acc;
        }
      }
  }

 private:
  int nx_;
  bool three_d_;
  int P_, Q_, rows_;
  size_t ring_size_;
  std::vector<std::vector<float>> rings_;
};

}  // namespace

// Xu & Prince's iteration v_new = v + dt (mu Lap v - b (v - c)), in wavefront blocks of up to
// max_depth iterations (0: chosen here; 1: the plain double-buffered loop) over tiles of
// tile_rows rows (0: chosen here). A block ends at
// every iteration whose residual is measured, so tolerance stopping sees the same iterates.
GvfSolveStats solve_explicit(Level& L, const std::vector<const std::vector<float>*>& c,
                             const std::vector<std::vector<float>*>& v, const GvfSolveOptions& o, double rhs_norm2,
                             int max_depth, int tile_rows) {
  const Coupling cp = coupling(L, o.mu);
  const double lap_max = 4.0 * (cp.cx + cp.cy + cp.cz);
  double b_max = 0;
  for (float x : L.b) b_max = std::max(b_max, double(x));
  const double bound = 2.0 / (lap_max + b_max);
  GvfSolveStats st;
  st.time_step = o.time_step > 0 ? o.time_step : 0.9 * bound;
  if (st.time_step >= bound)
    throw InputError("", "field.time_step",
                     "explicit GVF step " + std::to_string(o.time_step) + " is unstable: it must be < " +
                         std::to_string(bound) + " (2 / (b_max + 4 mu sum 1/h^2))");
  const int K = int(v.size());
  const int64_t rows = int64_t(L.ny) * L.nz;
  const int max_it = o.iterations > 0 ? o.iterations : 100000;
  const float dt = float(st.time_step);
  const int depth = max_depth > 0 ? max_depth : (L.nz > 1 ? kDepth3d : kDepth2d);
  const bool parallel = L.size() >= kParallelMin;
  const int threads = parallel ? omp_get_max_threads() : 1;
  // Tiles: 3D: ranges of ~kTileRows3d rows (y) over all slices; 2D: one range of rows per
  // thread (more tiles measured slower: each adds halo rows).
  const bool three_d = L.nz > 1;
  const int n_split = three_d ? std::max(1, (L.ny + kTileRows3d / 2) / kTileRows3d) : threads;
  const int rows_per_tile = tile_rows > 0 ? tile_rows : (L.ny + n_split - 1) / n_split;
  Wavefront wave(L, depth, three_d ? rows_per_tile : 1, threads);
  std::vector<Tile> tiles;
  for (int q = 0; q < L.ny; q += rows_per_tile) {
    const int end = std::min(L.ny, q + rows_per_tile);
    tiles.push_back(three_d ? Tile{0, L.nz, q, end} : Tile{q, end, 0, 1});
  }
  const int n_tiles = int(tiles.size());
  std::vector<std::vector<float>> next(K, std::vector<float>(L.size()));
  std::vector<float> row_acc(size_t(K) * rows);
  const int n_items = n_tiles * K;
  // The residual (= update / dt) is measured every kCheckEvery iterations and at the last one.
  constexpr int kCheckEvery = 10;
  for (int it = 0; it < max_it;) {
    const int next_check = o.tolerance > 0 ? std::min(max_it, (it / kCheckEvery + 1) * kCheckEvery) : max_it;
    const int T = std::min(depth, next_check - it);
    const bool measure = it + T == next_check;
    // The fields are independent (they share b only): one at a time keeps the rings small.
    // Dynamic: a thread that shares its core with another process takes fewer tiles.
#pragma omp parallel for schedule(dynamic, 1) if(parallel)
    for (int i = 0; i < n_items; ++i)
      wave.run_tile(tiles[i / K], T, i % K, v, next, c, L.b, cp, dt, measure, row_acc, omp_get_thread_num());
    for (int k = 0; k < K; ++k) v[k]->swap(next[k]);
    it += T;
    st.iterations = it;
    if (!measure) continue;
    double s = 0;
    for (int64_t yz = 0; yz < rows; ++yz) {  // per row, the fields in order (as the plain loop)
      double s2 = 0;
      for (int k = 0; k < K; ++k) s2 += row_acc[k * rows + yz];
      s += s2;
    }
    st.relative_residual = rhs_norm2 > 0 ? std::sqrt(s / rhs_norm2) : (s > 0 ? 1.0 : 0.0);
    if (o.tolerance > 0 && st.relative_residual <= o.tolerance) break;
  }
  return st;
}

}  // namespace dsnake::gvf_detail
