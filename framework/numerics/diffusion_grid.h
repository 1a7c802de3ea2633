// The grid as the diffusion solvers see it (grid_diffusion_solver.cpp, explicit_diffusion.cpp),
// with their row kernels, which the solvers' tests and the field benchmarks call directly.
// Every grid is 3D inside (a 2D grid has nz = 1 and no z neighbours), float arrays with x
// fastest, and loops run row by row with the neighbour rows resolved once per row.
#pragma once

#include "framework/numerics/grid_diffusion_solver.h"
#include "framework/core/vector_clones.h"

#include <cstdint>
#include <utility>
#include <vector>

namespace dsnake::gvf_detail {

// Grids smaller than this run on one thread (a parallel region costs more than the work).
constexpr int64_t kParallelMin = 32768;


// One grid of the multigrid hierarchy (level 0 is the image grid).
struct Level {
  int nx = 1, ny = 1, nz = 1;
  double h[3] = {1, 1, 1};  // spacing per axis, physical units
  int factor[3] = {1, 1, 1};  // coarsening factor from this level to the next (1 or 2)
  std::vector<float> b;                  // weight |grad f|^2 (averaged on coarse levels)
  std::vector<std::vector<float>> v, rhs;  // per field: the iterate and the right-hand side
  std::vector<std::vector<float>> res;     // per field: rhs - A v, where a caller keeps it (residual_rows)

  int64_t size() const { return int64_t(nx) * ny * nz; }
};

// Neighbour coupling mu / h_a^2 per axis, 0 along an axis of one voxel.
struct Coupling {
  float cx, cy, cz;
};
inline Coupling coupling(const Level& L, double mu) {
  return {L.nx > 1 ? float(mu / (L.h[0] * L.h[0])) : 0.f, L.ny > 1 ? float(mu / (L.h[1] * L.h[1])) : 0.f,
          L.nz > 1 ? float(mu / (L.h[2] * L.h[2])) : 0.f};
}

// Row pointers of a voxel row's neighbours; a missing neighbour has weight 0 (zero flux).
struct RowNeighbours {
  int64_t row, ym, yp, zm, zp;
  float wym, wyp, wzm, wzp;
};
inline RowNeighbours row_neighbours(const Level& L, const Coupling& c, int y, int z) {
  const int64_t nx = L.nx, row = (int64_t(z) * L.ny + y) * nx;
  RowNeighbours r{row, row, row, row, row, 0, 0, 0, 0};
  if (y > 0) r.ym = row - nx, r.wym = c.cy;
  if (y < L.ny - 1) r.yp = row + nx, r.wyp = c.cy;
  if (z > 0) r.zm = row - nx * L.ny, r.wzm = c.cz;
  if (z < L.nz - 1) r.zp = row + nx * L.ny, r.wzp = c.cz;
  return r;
}

template <int D>
inline Level level_of(const Grid<D>& grid) {
  Level L;
  L.nx = grid.size[0], L.ny = grid.size[1], L.nz = D == 3 ? grid.size[D - 1] : 1;
  for (int a = 0; a < D; ++a) L.h[a] = grid.spacing[a];
  return L;
}

// The multigrid smoother (grid_diffusion_solver.cpp): `sweeps` red-black Gauss-Seidel sweeps on L.v with
// right-hand side L.rhs, colour `first` first, in one pass over memory; the same result as the
// half-sweeps one after the other. 1 / A_ii is computed from L.b where it is used (no array).
// zero_start: L.v is taken as 0 on entry (not read).
void smooth_sweeps(Level& L, const Coupling& c, int first, int sweeps, bool zero_start = false);
// L.res = rhs - A v, row by row (L.res sized by the caller).
void residual_rows(Level& L, const Coupling& c);

// Grid transfer along one axis between a level and the next coarser one (grid_diffusion_solver.cpp):
// factor 2 coarsens cell-centred (even size) or vertex-centred (odd size), factor 1 is the identity.
struct AxisTransfer {
  std::vector<std::vector<std::pair<int, float>>> transpose, average;  // R = P^T / factor and R normalised, per coarse index
  // Prolongation: fine i = w_near * coarse near + (1 - w_near) * coarse far.
  std::vector<int> near, far;
  std::vector<float> w_near;
};
struct Transfer {
  AxisTransfer x, y, z;
};
// The transfers from F to C (F.factor set, C sized by it).
Transfer transfer(const Level& F, const Level& C);
// coarse = R fine (average = false: R = P^T / factor; true: R normalised to an average).
void restrict_to(const Level& F, const Level& C, const Transfer& t, bool average, const float* fine, float* coarse);
// coarse = R (F.rhs[k] - A F.v[k]) bit for bit as residual_rows then restrict_to(average = false),
// without an array of F's size: the cycle's restriction.
void restrict_residual(const Level& F, const Coupling& c, const Level& C, const Transfer& t, int k, float* coarse);

// The multigrid's grid transfers along a factor-2 x axis (grid_diffusion_solver.cpp), on one row. The
// coarse row (prolongation) or fine row (restriction) comes extended by one value at each end
// (ext[i + 1] = row[i]); see the functions for what the ends hold. Prolongation P is linear
// interpolation (cell-centred when n_fine is even, vertex-centred when odd); restriction is
// P^T / 2.
void prolongate_row_x2(float* out, const float* ext, int n_fine, int n_coarse);
void restrict_row_x2(float* out, const float* ext, int n_fine, int n_coarse);

// Xu & Prince's explicit iteration on a grid shaped like `shape` (its b is not read) with weights
// b (v: initial guess in, result out); rhs_norm2 = |b c|^2. Iterations run in temporally
// blocked wavefronts of up to max_depth iterations (0: the tuned depth; 1: the plain
// double-buffered loop) over tiles of tile_rows rows (3D: y-ranges of the slices; 2D: ranges of
// rows; 0: the tuned size), each level computing per_step planes (2D: rows) per wavefront step
// (0: the tuned count); the result depends on none of them.
// Throws InputError naming "field.time_step" for an unstable step (explicit_diffusion.cpp).
GvfSolveStats solve_explicit(const Level& shape, const std::vector<float>& b,
                             const std::vector<const std::vector<float>*>& c,
                             const std::vector<std::vector<float>*>& v, const GvfSolveOptions& o, double rhs_norm2,
                             int max_depth = 0, int tile_rows = 0, int per_step = 0);

}  // namespace dsnake::gvf_detail
