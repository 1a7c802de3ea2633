// Xu & Prince's explicit GVF iteration (1998), the reference solver; see grid_diffusion_solver.h.
//
// Temporal blocking: one sweep of v_new = v + dt (mu Lap v - b (v - c)) reads and writes every
// array once, so a plain double-buffered loop is bound by memory bandwidth. Here T consecutive
// iterations run as a wavefront over planes (z-slices in 3D, rows in 2D): time level t computes
// plane p from planes p-1..p+1 of level t-1 while they are still in cache, so the arrays stream
// from memory once per T iterations. A level computes R planes per step (R = 2 in 3D, 4 in 2D):
// all but the first of them find their sources and neighbour planes just touched by the level
// before, so fewer loads come from the outer caches (2D: 512^2 rows of 2 KB, L2-bound at R = 1).
// In 2D the R rows go through one pass over x (explicit_rows_body), which takes the y neighbours
// inside the group from registers: 3.5 loads per vector of a row instead of 5 at R = 4.
// The grid is cut into tiles (y-ranges of the slices in 3D, ranges of rows in 2D) that a thread
// sweeps on its own: level t of a tile also computes the T - t rows or planes around it that
// level t+1 reads (overlapped tiling: a little redundant work, no synchronisation). The
// intermediate levels live in one per-thread ring, in place: plane p of level t overwrites plane
// p-1 of level t-1, which that very computation reads last, so the ring holds about 2 T + R
// planes instead of (R + 2) (T - 1), and the write lands on lines just read (no fetch for
// ownership). A tile is swept one field at a time (the fields share only g = dt b), which keeps
// the ring small.
// Every voxel of every level is computed by the same row kernel from the same operands in the
// same order as the plain iteration (T = 1), so the results are bit-identical for every block
// depth, tile size and thread count. The solver works on its own padded copy of the system
// (PaddedSystem below): whole aligned vectors per row, with the x neighbours taken from
// shuffles (one lane-crossing shuffle per vector): a vector of voxels costs 5 aligned loads in
// 2D (7 in 3D), where the unpadded kernel made 9 (11), half of them split across cache lines
// (docs/methods.md: the 2D figure).
#include "framework/numerics/diffusion_grid.h"

#include "framework/core/errors.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <new>
#include <string>

#include <omp.h>

namespace dsnake::gvf_detail {

namespace {

// Wavefront shape, measured on 230 x 300 x 80 and 512^2 (see docs/performance.md): a block runs this many
// iterations (10 divides the residual-check interval, so tolerance runs keep full blocks); a 3D
// tile is about this many rows (y) of the slices; a level computes this many planes per step.
constexpr int kDepth3d = 10;
constexpr int kDepth2d = 10;
constexpr int kTileRows3d = 72;
constexpr int kPlanesPerStep3d = 2;
constexpr int kPlanesPerStep2d = 4;

// The explicit solver's own copy of the system, rows padded to whole vectors with one ghost
// vector on each side: row (y, z) has its voxel x at (z ny + y) stride + kLanes + x, stride =
// (blocks + 2) kLanes, every array 64-byte aligned. The ghosts carry the zero-flux reflection
// (u[-1] = u[0], u[nx] = u[nx-1]), so that the kernel's loop over a row has no special ends. In
// it v_new = v + d with d = s - (dd + g) v + dt mu Lap_side v, where g = dt b and s = dt b c are
// computed once per solve: per voxel the kernel loads the five stencil rows (the x neighbours
// come from shuffles of aligned vectors) and two coefficients.
constexpr int kLanes = 8;
// A Vec must point into an AlignedFloats: outside the AVX2 clone alignof(Vec) is only 16, so
// containers of Vec are not 32-byte aligned, and the clone's aligned loads would fault on them.
using Vec = float __attribute__((vector_size(kLanes * sizeof(float))));
using VecIndex = int __attribute__((vector_size(kLanes * sizeof(int))));

// A 64-byte aligned float array (aligned vector loads, no cache-line splits).
class AlignedFloats {
 public:
  AlignedFloats() = default;
  // zeroed = false leaves the contents undefined (for arrays written in full before any read).
  explicit AlignedFloats(size_t n, bool zeroed = true) : size_(n) {
    const size_t bytes = (n * sizeof(float) + 63) / 64 * 64;
    data_.reset(static_cast<float*>(std::aligned_alloc(64, std::max<size_t>(bytes, 64))));
    if (!data_) throw std::bad_alloc();
    if (zeroed) std::fill_n(data_.get(), n, 0.f);
  }
  float* data() { return data_.get(); }
  const float* data() const { return data_.get(); }
  size_t size() const { return size_; }

 private:
  struct Free {
    void operator()(float* p) const { std::free(p); }
  };
  std::unique_ptr<float[], Free> data_;
  size_t size_ = 0;
};

// The x neighbours of vector c of a padded row, from per-lane byte shifts of c and
// x = (upper half of c, lower half of next): right = (c1..c7, n0) from (c, x), and the next
// vector's left = (c7, n0..n6) from (x, next); xprev is the previous vector's x (for the left
// neighbours), so that a vector costs one lane-crossing shuffle instead of two. Inlined into
// each vector clone (out-parameters: a Vec return would change the ABI outside AVX).
[[gnu::always_inline]] inline void x_neighbours(const Vec& xprev, const Vec& c, const Vec& next, Vec& left,
                                                Vec& right, Vec& x) {
  x = DSNAKE_SHUFFLE2(c, next, VecIndex, 4, 5, 6, 7, 8, 9, 10, 11);         // halves
  left = DSNAKE_SHUFFLE2(xprev, c, VecIndex, 3, 8, 9, 10, 7, 12, 13, 14);   // to the left
  right = DSNAKE_SHUFFLE2(c, x, VecIndex, 1, 2, 3, 8, 5, 6, 7, 12);         // to the right
}

// x for the vector before the row's first one (its ghost vector).
[[gnu::always_inline]] inline void x_before(const Vec& ghost, const Vec& first, Vec& x) {
  x = DSNAKE_SHUFFLE2(ghost, first, VecIndex, 4, 5, 6, 7, 8, 9, 10, 11);  // halves
}

// The five input rows of a voxel row at one time level and their weights times dt (a missing
// neighbour points at the row itself with weight 0: zero flux). All rows are padded and aligned.
struct RowInputs {
  const float *u0, *uym, *uyp, *uzm, *uzp;
  float wym, wyp, wzm, wzp;
};

// One explicit step on a padded row of one field: out = u + d, d = s - (dd + g) u + dcx (u[x-1]
// + u[x+1]) + sum of the y and z neighbour terms, the x neighbours past the ends from the ghosts
// (zero flux); dd = dt (2 cx + the row's y and z weights); then out's ghosts are set. With
// `measure`, also acc = sum of d^2 over the row's nx voxels, summed in kLanes partial sums in a
// fixed order (the same for any thread count). The padding lanes are computed too (finite, never
// read as data) and left out of acc. Three copies of the loop, so that the common ones (no
// residual; 2D or 3D) carry no branch. `out` may be the row r.uym (2D) or r.uzm (3D) itself, the
// in-place ring: voxel x is stored after it was read, nothing else reads that row.
DSNAKE_VECTOR_CLONES
void explicit_row(const RowInputs& r, const float* __restrict s, const float* __restrict g, float* out,
                  float dcx, float dd, int nx, bool measure, float& acc) {
  const Vec* __restrict U = reinterpret_cast<const Vec*>(__builtin_assume_aligned(r.u0, 32));
  const Vec* YM = reinterpret_cast<const Vec*>(__builtin_assume_aligned(r.uym, 32));
  const Vec* __restrict YP = reinterpret_cast<const Vec*>(__builtin_assume_aligned(r.uyp, 32));
  const Vec* ZM = reinterpret_cast<const Vec*>(__builtin_assume_aligned(r.uzm, 32));
  const Vec* __restrict ZP = reinterpret_cast<const Vec*>(__builtin_assume_aligned(r.uzp, 32));
  const Vec* __restrict S = reinterpret_cast<const Vec*>(__builtin_assume_aligned(s, 32));
  const Vec* __restrict G = reinterpret_cast<const Vec*>(__builtin_assume_aligned(g, 32));
  Vec* O = reinterpret_cast<Vec*>(__builtin_assume_aligned(out, 32));
  const float wym = r.wym, wyp = r.wyp, wzm = r.wzm, wzp = r.wzp;
  // Without z neighbours (2D) their zero-weight terms are left out: adding 0 * u changes no value.
  const bool has_z = wzm != 0.f || wzp != 0.f;
  const int nb = (nx + kLanes - 1) / kLanes;
  Vec c = U[0], xprev, left, right, x;
  x_before(U[-1], c, xprev);
  if (!measure && !has_z) {
    for (int j = 0; j < nb; ++j) {
      const Vec next = U[j + 1];
      x_neighbours(xprev, c, next, left, right, x);
      const Vec d = S[j] - (dd + G[j]) * c + dcx * (left + right) + wym * YM[j] + wyp * YP[j];
      O[j] = c + d;
      xprev = x;
      c = next;
    }
  } else if (!measure) {
    for (int j = 0; j < nb; ++j) {
      const Vec next = U[j + 1];
      x_neighbours(xprev, c, next, left, right, x);
      Vec d = S[j] - (dd + G[j]) * c + dcx * (left + right) + wym * YM[j] + wyp * YP[j];
      d += wzm * ZM[j] + wzp * ZP[j];
      O[j] = c + d;
      xprev = x;
      c = next;
    }
  } else {
    const VecIndex lane = {0, 1, 2, 3, 4, 5, 6, 7};
    const int last_lane = (nx - 1) % kLanes;
    Vec sum = {};
    for (int j = 0; j < nb; ++j) {
      const Vec next = U[j + 1];
      x_neighbours(xprev, c, next, left, right, x);
      Vec d = S[j] - (dd + G[j]) * c + dcx * (left + right) + wym * YM[j] + wyp * YP[j];
      if (has_z) d += wzm * ZM[j] + wzp * ZP[j];
      O[j] = c + d;
      // d^2 over the row's voxels (the padding lanes of the last vector left out).
      const Vec dm = lane <= (j + 1 < nb ? kLanes - 1 : last_lane) ? d : Vec{};
      sum += dm * dm;
      xprev = x;
      c = next;
    }
    float a = 0.f;
    for (int l = 0; l < kLanes; ++l) a += sum[l];
    acc = a;
  }
  out[-1] = out[0], out[nx] = out[nx - 1];
}

// 2D: N consecutive interior rows of one level (each has both y neighbours) in one pass over x,
// the y neighbours inside the group taken from registers: a vector of each row costs 3 + 2 / N
// loads instead of 5, from the same operands in the same order as explicit_row (bit-identical).
// Row i of the inputs u, the sources s, g and the output out is at i * stride floats from row 0
// (the caller cuts groups where the ring wraps); top / bottom are the rows above and below the
// group; dd = 2 (dcx + wy). In place: out's row i may be u's row i - 1 (or top for i = 0):
// column j of it is in a register before column j of out's row i is stored, and nothing reads
// it later. The addresses are a pointer per array plus a row offset shared by all arrays, so
// that N = 4 fits the general registers.
template <int N>
[[gnu::always_inline]] inline void explicit_rows_body(const float* u, const float* top, const float* bottom,
                                                      const float* s, const float* g, float* out,
                                                      ptrdiff_t stride, float dcx, float wy, float dd, int nx) {
  const char* U = static_cast<const char*>(__builtin_assume_aligned(u, 32));
  const char* S = static_cast<const char*>(__builtin_assume_aligned(s, 32));
  const char* G = static_cast<const char*>(__builtin_assume_aligned(g, 32));
  char* O = static_cast<char*>(__builtin_assume_aligned(out, 32));
  const Vec* TOP = reinterpret_cast<const Vec*>(__builtin_assume_aligned(top, 32));
  const Vec* BOT = reinterpret_cast<const Vec*>(__builtin_assume_aligned(bottom, 32));
  ptrdiff_t off[N];
  for (int i = 0; i < N; ++i) off[i] = i * stride * ptrdiff_t(sizeof(float));
  const int nb = (nx + kLanes - 1) / kLanes;
  Vec xprev[N], c[N];
  for (int i = 0; i < N; ++i) {
    c[i] = *reinterpret_cast<const Vec*>(U + off[i]);
    x_before(*reinterpret_cast<const Vec*>(U + off[i] - sizeof(Vec)), c[i], xprev[i]);
  }
  for (int j = 0; j < nb; ++j) {
    Vec next[N], o[N], x[N];
    for (int i = 0; i < N; ++i) next[i] = *reinterpret_cast<const Vec*>(U + off[i] + sizeof(Vec));
    const Vec above = TOP[j], below = BOT[j];
    for (int i = 0; i < N; ++i) {
      Vec left, right;
      x_neighbours(xprev[i], c[i], next[i], left, right, x[i]);
      const Vec ym = i == 0 ? above : c[i - 1], yp = i == N - 1 ? below : c[i + 1];
      const Vec s_i = *reinterpret_cast<const Vec*>(S + off[i]), g_i = *reinterpret_cast<const Vec*>(G + off[i]);
      const Vec d = s_i - (dd + g_i) * c[i] + dcx * (left + right) + wy * ym + wy * yp;
      o[i] = c[i] + d;
    }
    for (int i = 0; i < N; ++i) *reinterpret_cast<Vec*>(O + off[i]) = o[i], xprev[i] = x[i], c[i] = next[i];
    U += sizeof(Vec), S += sizeof(Vec), G += sizeof(Vec), O += sizeof(Vec);
  }
  for (int i = 0; i < N; ++i) {
    float* row = out + i * stride;
    row[-1] = row[0], row[nx] = row[nx - 1];
  }
}

constexpr int kMaxRowsPerPass = 4;

// explicit_rows_body for 2 <= n <= kMaxRowsPerPass rows.
DSNAKE_VECTOR_CLONES
void explicit_rows_2d(int n, const float* u, const float* top, const float* bottom, const float* s, const float* g,
                      float* out, ptrdiff_t stride, float dcx, float wy, float dd, int nx) {
  switch (n) {
    case 2: return explicit_rows_body<2>(u, top, bottom, s, g, out, stride, dcx, wy, dd, nx);
    case 3: return explicit_rows_body<3>(u, top, bottom, s, g, out, stride, dcx, wy, dd, nx);
    default: return explicit_rows_body<4>(u, top, bottom, s, g, out, stride, dcx, wy, dd, nx);
  }
}

// A tile: planes [p0, p1) x rows [q0, q1) of the output level. Planes are z-slices in 3D
// (rows q = y within them) and rows in 2D (one "row" q = 0 per plane).
struct Tile {
  int p0, p1, q0, q1;
};

// The solver's padded copy of the system (see AlignedFloats): the fields v (iterate) and next,
// the sources s_k = g c_k and g = dt b.
struct PaddedSystem {
  int nx, stride;
  int64_t rows;
  AlignedFloats g;
  std::vector<AlignedFloats> s, v, next;
  // The first voxel of row yz (after the row's left ghost vector).
  float* row(AlignedFloats& a, int64_t yz) const { return a.data() + yz * stride + kLanes; }
  const float* row(const AlignedFloats& a, int64_t yz) const { return a.data() + yz * stride + kLanes; }
};

// The weights of one explicit step, times dt: dcx, dcy, dcz = dt mu / h^2 per axis.
struct StepWeights {
  float dcx, dcy, dcz;
};

// The per-thread rings of a block of up to max_depth iterations over tiles of up to tile_rows
// rows, per_step planes per level and step; runs one field's wavefront over a tile. Row (p, q)
// of the grid is row p Q + q.
class Wavefront {
 public:
  // Sizes the rings (the only allocation): levels 1..max_depth-1 share 2 max_depth + per_step
  // planes (rounded up to a power of two), plane p of level t in slot p - t (see run_tile).
  Wavefront(const Level& L, int stride, int max_depth, int tile_rows, int per_step, int threads)
      : nx_(L.nx), stride_(stride), three_d_(L.nz > 1), P_(three_d_ ? L.nz : L.ny), Q_(three_d_ ? L.ny : 1),
        rows_(std::min(Q_, tile_rows + 2 * (max_depth - 1))), per_step_(per_step),
        slots_(int(std::bit_ceil(unsigned(2 * max_depth + per_step)))) {
    const size_t ring_size = size_t(slots_) * rows_ * stride_;
    for (int i = 0; i < threads; ++i) rings_.emplace_back(ring_size);
  }

  // Runs T iterations (1 <= T <= max_depth) of field k on the tile from sys.v into sys.next;
  // with `measure`, also row_acc[k rows + p Q + q] = the last iteration's sum of d^2 of field k
  // on that row.
  void run_tile(const Tile& tile, int T, int k, PaddedSystem& sys, const StepWeights& w, bool measure,
                std::vector<float>& row_acc, int thread) {
    float* ring = rings_[thread].data();
    const int base_p = tile.p0 - (T - 1), base_q = std::max(0, tile.q0 - (T - 1));
    const int64_t plane_size = int64_t(Q_) * stride_;
    // Plane p of field k at level t as an input (0: v) or output (T: next): its first stored row
    // and that row's index q (a ring plane starts at base_q, a grid plane at 0).
    struct PlaneRef {
      float* first;
      int q_first;
    };
    // Ring slot of plane p at level t: p - t, so that level t writes plane p over plane p-1 of
    // level t-1, its last reader. The planes still to be read at any moment (the last two of
    // each level, R + 2 of the level about to read them; each level one plane behind the one
    // before) span fewer than 2 T + R consecutive slots.
    auto plane_at = [&](int t, int p) -> PlaneRef {
      if (t == 0) return {sys.v[k].data() + p * plane_size + kLanes, 0};
      if (t == T) return {sys.next[k].data() + p * plane_size + kLanes, 0};
      return {ring + int64_t((p - t - base_p + 1) & (slots_ - 1)) * rows_ * stride_ + kLanes, base_q};
    };
    auto row_of = [&](const PlaneRef& plane, int q) { return plane.first + int64_t(q - plane.q_first) * stride_; };
    const float w_across = three_d_ ? w.dcz : w.dcy;
    // Step s: level t computes planes base_p + R s - (t - 1) + [0, R), R = per_step_, after
    // level t-1 computed the planes one further.
    const int R = per_step_;
    for (int s = 0; R * s < tile.p1 - tile.p0 + 2 * (T - 1); ++s)
      for (int t = 1; t <= T; ++t)
        for (int p = base_p + R * s - (t - 1), p_end = p + R, grow = T - t; p < p_end; ++p) {
          if (p < std::max(0, tile.p0 - grow) || p >= std::min(P_, tile.p1 + grow)) continue;
          if (!three_d_ && !(measure && t == T) && p > 0) {
            // 2D, interior rows: the step's rows in passes of up to kMaxRowsPerPass, cut where
            // the ring wraps (rows at a constant stride); a single row goes to explicit_row.
            // (A ring level's plane p is in slot (p - t - base_p + 1) mod slots_, see plane_at.)
            auto to_wrap = [&](int level) {
              if (level == 0 || level == T) return kMaxRowsPerPass;
              return slots_ - ((p - level - base_p + 1) & (slots_ - 1));
            };
            const int n =
                std::min({p_end, tile.p1 + grow, P_ - 1, p + kMaxRowsPerPass, p + to_wrap(t - 1), p + to_wrap(t)}) - p;
            if (n > 1) {
              const float* u = plane_at(t - 1, p).first;
              float* o = plane_at(t, p).first;
              explicit_rows_2d(n, u, plane_at(t - 1, p - 1).first, plane_at(t - 1, p + n).first,
                               sys.row(sys.s[k], p), sys.row(sys.g, p), o, stride_, w.dcx, w.dcy,
                               2.f * w.dcx + (w.dcy + w.dcy + 0.f + 0.f), nx_);  // dd as below
              p += n - 1;
              continue;
            }
          }
          const int q_lo = std::max(0, tile.q0 - grow), q_hi = std::min(Q_, tile.q1 + grow);
          // Neighbour planes (the plane itself, weight 0, at the border): z in 3D, y in 2D.
          const PlaneRef in = plane_at(t - 1, p), out = plane_at(t, p);
          const PlaneRef in_m = p > 0 ? plane_at(t - 1, p - 1) : in, in_p = p < P_ - 1 ? plane_at(t - 1, p + 1) : in;
          const float wm = p > 0 ? w_across : 0.f, wp = p < P_ - 1 ? w_across : 0.f;
          const bool last = measure && t == T;
          for (int q = q_lo; q < q_hi; ++q) {
            const int64_t yz = int64_t(p) * Q_ + q;
            const float* u0 = row_of(in, q);
            RowInputs r{u0, u0, u0, u0, u0, 0, 0, 0, 0};
            if (three_d_) {  // y neighbours in the plane (rows are contiguous), z across planes
              if (q > 0) r.uym = u0 - stride_, r.wym = w.dcy;
              if (q < Q_ - 1) r.uyp = u0 + stride_, r.wyp = w.dcy;
              r.uzm = row_of(in_m, q), r.wzm = wm;
              r.uzp = row_of(in_p, q), r.wzp = wp;
            } else {  // 2D: y neighbours across planes (rows), no z
              r.uym = row_of(in_m, q), r.wym = wm;
              r.uyp = row_of(in_p, q), r.wyp = wp;
            }
            const float dd = 2.f * w.dcx + (r.wym + r.wyp + r.wzm + r.wzp);
            float acc = 0.f;
            explicit_row(r, sys.row(sys.s[k], yz), sys.row(sys.g, yz), row_of(out, q), w.dcx, dd, nx_, last, acc);
            if (last) row_acc[k * int64_t(P_) * Q_ + yz] = acc;
          }
        }
  }

 private:
  int nx_, stride_;
  bool three_d_;
  int P_, Q_, rows_, per_step_, slots_;
  std::vector<AlignedFloats> rings_;
};

// The explicit step dt: the one asked for, or 0.9 x the stability bound 2 / (b_max + 4 mu sum
// 1/h^2); throws InputError naming "field.time_step" for a step at or past the bound.
double stable_time_step(const Level& L, const std::vector<float>& b, const Coupling& cp, const GvfSolveOptions& o) {
  const double lap_max = 4.0 * (cp.cx + cp.cy + cp.cz);
  float lane_max[kLanes] = {};  // in kLanes partial maxima, which vectorises
  const int64_t n = L.size();
  for (int64_t l = 0; l + kLanes <= n; l += kLanes)
    for (int j = 0; j < kLanes; ++j) lane_max[j] = b[l + j] > lane_max[j] ? b[l + j] : lane_max[j];
  float b_max = 0.f;
  for (int64_t l = n / kLanes * kLanes; l < n; ++l) b_max = b[l] > b_max ? b[l] : b_max;
  for (float m : lane_max) b_max = m > b_max ? m : b_max;
  const double bound = 2.0 / (lap_max + b_max);
  const double time_step = o.time_step > 0 ? o.time_step : 0.9 * bound;
  if (time_step >= bound)
    throw InputError("", "field.time_step",
                     "explicit GVF step " + std::to_string(o.time_step) + " is unstable: it must be < " +
                         std::to_string(bound) + " (2 / (b_max + 4 mu sum 1/h^2))");
  return time_step;
}

// The padded copy: g = dt b, s_k = g c_k, v_k (copied back into v by copy_back).
PaddedSystem padded_system(const Level& L, const std::vector<float>& b, const std::vector<const std::vector<float>*>& c,
                           const std::vector<std::vector<float>*>& v, float dt, bool parallel) {
  const int K = int(v.size());
  const int64_t rows = int64_t(L.ny) * L.nz;
  PaddedSystem sys;
  sys.nx = L.nx, sys.stride = ((L.nx + kLanes - 1) / kLanes + 2) * kLanes, sys.rows = rows;
  const size_t padded = size_t(rows) * sys.stride;
  // g, s and v are written in full below (ghosts and padding included); next is zeroed, so that
  // the padding lanes its blocks compute from it stay finite.
  sys.g = AlignedFloats(padded, false);
  for (int k = 0; k < K; ++k)
    sys.s.emplace_back(padded, false), sys.v.emplace_back(padded, false), sys.next.emplace_back(padded, true);
  const int tail = sys.stride - kLanes - L.nx;  // padding after the row's last voxel
#pragma omp parallel for schedule(static) if(parallel)
  for (int64_t yz = 0; yz < rows; ++yz) {
    const int64_t src = yz * L.nx;
    float* g = sys.row(sys.g, yz);
    for (int x = 0; x < L.nx; ++x) g[x] = dt * b[src + x];
    std::fill_n(g - kLanes, kLanes, 0.f), std::fill_n(g + L.nx, tail, 0.f);
    for (int k = 0; k < K; ++k) {
      float *s = sys.row(sys.s[k], yz), *vk = sys.row(sys.v[k], yz);
      const float *ck = c[k]->data() + src, *v0 = v[k]->data() + src;
      for (int x = 0; x < L.nx; ++x) s[x] = g[x] * ck[x];
      std::copy_n(v0, L.nx, vk);
      std::fill_n(s - kLanes, kLanes, 0.f), std::fill_n(s + L.nx, tail, 0.f);
      std::fill_n(vk - kLanes, kLanes, 0.f), std::fill_n(vk + L.nx, tail, 0.f);
      vk[-1] = vk[0], vk[L.nx] = vk[L.nx - 1];  // the zero-flux ghosts
    }
  }
  return sys;
}

// The iterates of the padded system back into v.
void copy_back(const Level& L, PaddedSystem& sys, const std::vector<std::vector<float>*>& v, bool parallel) {
  const int K = int(v.size());
#pragma omp parallel for schedule(static) if(parallel)
  for (int64_t yz = 0; yz < sys.rows; ++yz) {
    for (int k = 0; k < K; ++k) std::copy_n(sys.row(sys.v[k], yz), L.nx, v[k]->data() + yz * L.nx);
  }
}

// Tiles: 3D: ranges of rows_per_tile rows (y) over all slices; 2D: ranges of rows_per_tile rows.
std::vector<Tile> make_tiles(const Level& L, int rows_per_tile) {
  const bool three_d = L.nz > 1;
  std::vector<Tile> tiles;
  for (int q = 0; q < L.ny; q += rows_per_tile) {
    const int end = std::min(L.ny, q + rows_per_tile);
    tiles.push_back(three_d ? Tile{0, L.nz, q, end} : Tile{q, end, 0, 1});
  }
  return tiles;
}

// |d|^2 / dt^2 of the last measured iteration (d the update), summed per row over the fields
// in order, then over the rows in order (thread-count independent).
double measured_residual2(const std::vector<float>& row_acc, int K, int64_t rows, float dt) {
  double sum = 0;
  for (int64_t yz = 0; yz < rows; ++yz) {  // per row, the fields in order
    double s2 = 0;
    for (int k = 0; k < K; ++k) s2 += row_acc[k * rows + yz];
    sum += s2;
  }
  return sum / (double(dt) * double(dt));
}

}  // namespace

// Xu & Prince's iteration v_new = v + dt (mu Lap v - b (v - c)), in wavefront blocks of up to
// max_depth iterations (0: chosen here; 1: the plain double-buffered loop) over tiles of
// tile_rows rows (0: chosen here), on a padded copy of the system. A block ends at every
// iteration whose residual is measured, so tolerance stopping sees the same iterates.
GvfSolveStats solve_explicit(const Level& L, const std::vector<float>& b,
                             const std::vector<const std::vector<float>*>& c,
                             const std::vector<std::vector<float>*>& v, const GvfSolveOptions& o, double rhs_norm2,
                             int max_depth, int tile_rows, int per_step) {
  const Coupling cp = coupling(L, o.mu);
  GvfSolveStats st;
  st.time_step = stable_time_step(L, b, cp, o);
  const int K = int(v.size());
  const int64_t rows = int64_t(L.ny) * L.nz;
  const int max_it = o.iterations > 0 ? o.iterations : 100000;
  const float dt = float(st.time_step);
  const StepWeights w{dt * cp.cx, dt * cp.cy, dt * cp.cz};
  const int depth = max_depth > 0 ? max_depth : (L.nz > 1 ? kDepth3d : kDepth2d);
  const bool parallel = L.size() >= kParallelMin;
  const int threads = parallel ? omp_get_max_threads() : 1;
  PaddedSystem sys = padded_system(L, b, c, v, dt, parallel);

  // Tiles: 3D: ranges of ~kTileRows3d rows (y) over all slices; 2D: one range of rows per
  // thread (more tiles measured slower: each adds halo rows).
  const bool three_d = L.nz > 1;
  const int n_split = three_d ? std::max(1, (L.ny + kTileRows3d / 2) / kTileRows3d) : threads;
  const int rows_per_tile = tile_rows > 0 ? tile_rows : (L.ny + n_split - 1) / n_split;
  const int planes_per_step = per_step > 0 ? per_step : (three_d ? kPlanesPerStep3d : kPlanesPerStep2d);
  Wavefront wave(L, sys.stride, depth, three_d ? rows_per_tile : 1, planes_per_step, threads);
  const std::vector<Tile> tiles = make_tiles(L, rows_per_tile);
  std::vector<float> row_acc(size_t(K) * rows);
  const int n_items = int(tiles.size()) * K;
  // The residual e = d / dt is measured every kCheckEvery iterations and at the last one.
  constexpr int kCheckEvery = 10;
  for (int it = 0; it < max_it;) {
    const int next_check = o.tolerance > 0 ? std::min(max_it, (it / kCheckEvery + 1) * kCheckEvery) : max_it;
    const int T = std::min(depth, next_check - it);
    const bool measure = it + T == next_check;
    // The fields are independent (they share g only): one at a time keeps the rings small.
    // Dynamic: a thread that shares its core with another process takes fewer tiles.
#pragma omp parallel for schedule(dynamic, 1) if(parallel)
    for (int i = 0; i < n_items; ++i)
      wave.run_tile(tiles[i / K], T, i % K, sys, w, measure, row_acc, omp_get_thread_num());
    for (int k = 0; k < K; ++k) std::swap(sys.v[k], sys.next[k]);
    it += T;
    st.iterations = it;
    if (!measure) continue;
    const double sum = measured_residual2(row_acc, K, rows, dt);
    st.relative_residual = rhs_norm2 > 0 ? std::sqrt(sum / rhs_norm2) : (sum > 0 ? 1.0 : 0.0);
    if (o.tolerance > 0 && st.relative_residual <= o.tolerance) break;
  }
  copy_back(L, sys, v, parallel);
  return st;
}

}  // namespace dsnake::gvf_detail
