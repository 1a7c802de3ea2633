// The explicit GVF solver's temporal blocking (framework/numerics/explicit_diffusion.cpp): every wavefront depth
// gives bit-for-bit the plain double-buffered iteration (depth 1), with and without tolerance
// stopping, for 1 and 2 threads, on odd and degenerate grids with anisotropic spacing; and the
// plain iteration matches an independent double-precision loop written here.
#include "fields/ddgvf.h"
#include "framework/numerics/diffusion_grid.h"
#include "framework/core/errors.h"

#include <cmath>
#include <cstring>
#include <gtest/gtest.h>
#include <omp.h>
#include <random>

namespace dsnake {
namespace {

using gvf_detail::Level;

// A GVF system on an nx x ny x nz grid (nz = 1: a 2D grid) with spacing h: b in [0, 2), sources
// c in [-1, 1] and the initial guess v = c / 2, pseudo-random from a fixed seed.
struct System {
  Level L;
  int K;
  std::vector<std::vector<float>> c, v;
  double rhs_norm2 = 0;
  System(int nx, int ny, int nz, const double (&h)[3], int K_, unsigned seed = 7) : K(K_) {
    L.nx = nx, L.ny = ny, L.nz = nz;
    for (int a = 0; a < 3; ++a) L.h[a] = h[a];
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.f, 1.f);
    L.b.resize(L.size());
    for (float& x : L.b) x = 2.f * unit(rng) * unit(rng);
    c.assign(K, std::vector<float>(L.size()));
    for (auto& ck : c)
      for (float& x : ck) x = 2.f * unit(rng) - 1.f;
    v = c;
    for (auto& vk : v)
      for (float& x : vk) x *= 0.5f;
    for (int k = 0; k < K; ++k)
      for (int64_t l = 0; l < L.size(); ++l) rhs_norm2 += std::pow(double(L.b[l]) * c[k][l], 2);
  }
};

struct Solution {
  GvfSolveStats stats;
  std::vector<std::vector<float>> v;
};

// Runs the explicit solver on a copy of s's initial guess with wavefront depth `depth` over
// tiles of tile_rows rows (0: the default tiles), per_step planes per level and step (0: default).
Solution solve(const System& s, const GvfSolveOptions& o, int depth, int threads = 1, int tile_rows = 0,
               int per_step = 0) {
  Level L = s.L;
  Solution run;
  run.v = s.v;
  std::vector<const std::vector<float>*> c;
  std::vector<std::vector<float>*> v;
  for (int k = 0; k < s.K; ++k) c.push_back(&s.c[k]), v.push_back(&run.v[k]);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads);
  run.stats = gvf_detail::solve_explicit(L, L.b, c, v, o, s.rhs_norm2, depth, tile_rows, per_step);
  omp_set_num_threads(saved);
  return run;
}

// True when the two runs stopped at the same iteration with the same residual and fields (bits).
::testing::AssertionResult identical(const Solution& a, const Solution& b) {
  if (a.stats.iterations != b.stats.iterations)
    return ::testing::AssertionFailure() << "iterations " << a.stats.iterations << " vs " << b.stats.iterations;
  if (a.stats.relative_residual != b.stats.relative_residual)
    return ::testing::AssertionFailure() << "residual " << a.stats.relative_residual << " vs "
                                         << b.stats.relative_residual;
  for (size_t k = 0; k < a.v.size(); ++k)
    for (size_t l = 0; l < a.v[k].size(); ++l)
      if (std::memcmp(&a.v[k][l], &b.v[k][l], sizeof(float)) != 0)
        return ::testing::AssertionFailure() << "field " << k << " voxel " << l << ": " << a.v[k][l] << " vs "
                                             << b.v[k][l];
  return ::testing::AssertionSuccess();
}

// The grids: odd sizes, anisotropic spacing, 2D (nz = 1), thin volumes (nz = 2, 3), a single
// row or column, and a single voxel.
struct Shape {
  int nx, ny, nz, K;
};
const Shape kShapes[] = {{13, 11, 9, 3}, {17, 23, 1, 2}, {9, 7, 2, 3}, {10, 5, 3, 3},
                         {1, 6, 5, 3},   {31, 1, 1, 2},  {1, 1, 1, 2}, {257, 9, 1, 2}};
const double kSpacing[3] = {1.0, 1.3, 2.5};

TEST(GvfExplicitWavefront, EveryDepthGivesThePlainIterationBitForBit) {
  for (const Shape& sh : kShapes) {
    const System s(sh.nx, sh.ny, sh.nz, kSpacing, sh.K);
    GvfSolveOptions o;
    o.mu = 0.2, o.tolerance = 0, o.iterations = 23;  // not a multiple of any depth but 1
    const Solution plain = solve(s, o, 1);
    EXPECT_EQ(plain.stats.iterations, 23);
    EXPECT_GT(plain.stats.relative_residual, 0);
    for (int depth : {1, 2, 3, 4, 5, 8, 30})
      for (int tile_rows : {0, 1, 2, 5})  // tiles of y-rows in 3D, of rows in 2D
        for (int per_step : {1, 2, 3, 7})  // planes per level and wavefront step
          EXPECT_TRUE(identical(plain, solve(s, o, depth, 1, tile_rows, per_step)))
              << sh.nx << "x" << sh.ny << "x" << sh.nz << " depth " << depth << " tile rows " << tile_rows
              << " planes per step " << per_step;
    EXPECT_TRUE(identical(plain, solve(s, o, 0))) << sh.nx << "x" << sh.ny << "x" << sh.nz << " default depth";
  }
}

TEST(GvfExplicitWavefront, ToleranceStopsAtTheSameIteration) {
  for (const Shape& sh : {kShapes[0], kShapes[1], kShapes[3]}) {
    const System s(sh.nx, sh.ny, sh.nz, kSpacing, sh.K);
    GvfSolveOptions o;
    o.mu = 0.2, o.iterations = 0, o.tolerance = 0;
    // The residual after 37 plain iterations is reached between checks 30 and 40: stop at 40.
    o.iterations = 37;
    const double tol = solve(s, o, 1).stats.relative_residual;
    o.iterations = 0, o.tolerance = tol;
    const Solution plain = solve(s, o, 1);
    EXPECT_EQ(plain.stats.iterations, 40) << sh.nx << "x" << sh.ny << "x" << sh.nz;
    EXPECT_LE(plain.stats.relative_residual, tol);
    for (int depth : {3, 4, 7, 8, 16})
      for (int per_step : {1, 4})
        EXPECT_TRUE(identical(plain, solve(s, o, depth, 1, 3, per_step))) << "depth " << depth << " per step " << per_step;
    // An iteration cap that is not a multiple of the check interval: measured at the cap.
    o.iterations = 26, o.tolerance = 1e-12;
    const Solution capped = solve(s, o, 1);
    EXPECT_EQ(capped.stats.iterations, 26);
    for (int depth : {4, 8}) EXPECT_TRUE(identical(capped, solve(s, o, depth))) << "capped, depth " << depth;
  }
}

TEST(GvfExplicitWavefront, OneAndTwoThreadsAgreeBitForBit) {
  // Above the parallel threshold (32768 voxels), so that the second thread takes part.
  for (const Shape& sh : {Shape{41, 37, 29, 3}, Shape{203, 190, 1, 2}}) {
    const System s(sh.nx, sh.ny, sh.nz, kSpacing, sh.K);
    GvfSolveOptions o;
    o.mu = 0.2, o.tolerance = 0, o.iterations = 13;
    const Solution plain = solve(s, o, 1, 1);
    for (int threads : {1, 2})
      for (int depth : {1, 0, 5})
        for (int tile_rows : {0, 7})
          for (int per_step : {0, 1, 3})
            EXPECT_TRUE(identical(plain, solve(s, o, depth, threads, tile_rows, per_step)))
                << sh.nz << " slices, threads " << threads << " depth " << depth << " tile rows " << tile_rows
                << " planes per step " << per_step;
  }
}

// The explicit step as the solver defines it (explicit_diffusion.cpp), restated voxel by voxel on
// unpadded rows: d = s - (dd + g) u + dcx (u[x-1] + u[x+1]) + y terms (+ z terms), u[-1] = u[0]
// and u[nx] = u[nx-1], out = u + d, with g = dt b, s = g c, weights times dt, and with
// `measure` acc = the sum of d^2 in 8 partial sums by x mod 8. Same vector clones as the
// library, so that both are compiled alike (FMA contraction included). The solver computes
// the x neighbours by shuffling whole vectors of padded, aligned rows: this scalar loop is
// the reference its shuffles, borders and padding must reproduce bit for bit.
DSNAKE_VECTOR_CLONES
void plain_row(const float* u, const float* s_row, const float* g_row, float* next, const gvf_detail::RowNeighbours& r,
               float dcx, float dwym, float dwyp, float dwzm, float dwzp, float dd, int nx, bool measure, float& acc) {
  const float *__restrict u0 = u + r.row, *__restrict uym = u + r.ym, *__restrict uyp = u + r.yp,
              *__restrict uzm = u + r.zm, *__restrict uzp = u + r.zp;
  float* __restrict out = next + r.row;
  const bool has_z = dwzm != 0.f || dwzp != 0.f;
  float lanes[8] = {};
  for (int x = 0; x < nx; ++x) {
    const float left = x > 0 ? u0[x - 1] : u0[x], right = x < nx - 1 ? u0[x + 1] : u0[x];
    float d = s_row[x] - (dd + g_row[x]) * u0[x] + dcx * (left + right) + dwym * uym[x] + dwyp * uyp[x];
    if (has_z) d += dwzm * uzm[x] + dwzp * uzp[x];
    out[x] = u0[x] + d;
    lanes[x % 8] += d * d;
  }
  if (measure) {
    float a = 0.f;
    for (float l : lanes) a += l;
    acc = a;
  }
}

// A plain double-buffered solve around plain_row (time step given, tolerance 0).
Solution plain_solve(const System& s, double time_step, int iterations) {
  Level L = s.L;
  const gvf_detail::Coupling cp = gvf_detail::coupling(L, 0.2);
  const float dt = float(time_step);
  Solution run;
  run.v = s.v;
  std::vector<std::vector<float>> next = run.v, src = s.c;
  std::vector<float> g(L.size());
  for (int64_t l = 0; l < L.size(); ++l) g[l] = dt * L.b[l];
  for (int k = 0; k < s.K; ++k)
    for (int64_t l = 0; l < L.size(); ++l) src[k][l] = g[l] * s.c[k][l];
  const int64_t rows = int64_t(L.ny) * L.nz;
  std::vector<double> row_sum(rows);
  for (int it = 0; it < iterations; ++it) {
    const bool measure = it + 1 == iterations;
    for (int64_t yz = 0; yz < rows; ++yz) {
      const gvf_detail::RowNeighbours r = gvf_detail::row_neighbours(L, cp, int(yz % L.ny), int(yz / L.ny));
      // The neighbour weights times dt, as the solver forms them (dt mu / h^2, 0 if missing).
      const float dwym = r.wym != 0 ? dt * cp.cy : 0.f, dwyp = r.wyp != 0 ? dt * cp.cy : 0.f;
      const float dwzm = r.wzm != 0 ? dt * cp.cz : 0.f, dwzp = r.wzp != 0 ? dt * cp.cz : 0.f;
      const float dcx = dt * cp.cx, dd = 2.f * dcx + (dwym + dwyp + dwzm + dwzp);
      double s2 = 0;
      for (int k = 0; k < s.K; ++k) {
        float acc = 0.f;
        plain_row(run.v[k].data(), src[k].data() + r.row, g.data() + r.row, next[k].data(), r, dcx, dwym, dwyp, dwzm,
                  dwzp, dd, L.nx, measure, acc);
        s2 += acc;
      }
      row_sum[yz] = s2;
    }
    for (int k = 0; k < s.K; ++k) run.v[k].swap(next[k]);
  }
  double sum = 0;
  for (int64_t yz = 0; yz < rows; ++yz) sum += row_sum[yz];
  sum /= double(dt) * double(dt);
  run.stats.iterations = iterations;
  run.stats.relative_residual = std::sqrt(sum / s.rhs_norm2);
  run.stats.time_step = time_step;
  return run;
}

TEST(GvfExplicitWavefront, ReproducesAScalarStatementOfTheStep) {
  for (const Shape& sh : kShapes) {
    const System s(sh.nx, sh.ny, sh.nz, kSpacing, sh.K);
    GvfSolveOptions o;
    o.mu = 0.2, o.tolerance = 0, o.iterations = 27;
    const Solution now = solve(s, o, 0);
    EXPECT_TRUE(identical(plain_solve(s, now.stats.time_step, 27), now)) << sh.nx << "x" << sh.ny << "x" << sh.nz;
  }
}

// Xu & Prince's iteration in double precision, written voxel by voxel from the equation:
// v += dt (mu sum_a (v[+a] - 2 v + v[-a]) / h_a^2 - b (v - c)), a missing neighbour replaced
// by the voxel itself (zero flux). Returns the relative residual of the last update.
double reference(const System& s, double dt, int iterations, std::vector<std::vector<double>>& v) {
  const Level& L = s.L;
  const int n[3] = {L.nx, L.ny, L.nz};
  const int64_t stride[3] = {1, L.nx, int64_t(L.nx) * L.ny};
  v.assign(s.K, {});
  for (int k = 0; k < s.K; ++k) v[k].assign(s.v[k].begin(), s.v[k].end());
  double r2 = 0;
  for (int it = 0; it < iterations; ++it) {
    r2 = 0;
    for (int k = 0; k < s.K; ++k) {
      std::vector<double> next(v[k].size());
      for (int z = 0; z < L.nz; ++z)
        for (int y = 0; y < L.ny; ++y)
          for (int x = 0; x < L.nx; ++x) {
            const int idx[3] = {x, y, z};
            const int64_t l = x + stride[1] * y + stride[2] * z;
            double lap = 0;
            for (int a = 0; a < 3; ++a) {
              const double lo = idx[a] > 0 ? v[k][l - stride[a]] : v[k][l];
              const double hi = idx[a] < n[a] - 1 ? v[k][l + stride[a]] : v[k][l];
              lap += (lo - 2 * v[k][l] + hi) / (L.h[a] * L.h[a]);
            }
            const double e = 0.2 * lap - L.b[l] * (v[k][l] - s.c[k][l]);
            next[l] = v[k][l] + dt * e;
            r2 += e * e;
          }
      v[k] = next;
    }
  }
  return std::sqrt(r2 / s.rhs_norm2);
}

TEST(GvfExplicitWavefront, MatchesAnIndependentDoublePrecisionLoop) {
  for (const Shape& sh : {kShapes[0], kShapes[1], kShapes[2], kShapes[4]}) {
    const System s(sh.nx, sh.ny, sh.nz, kSpacing, sh.K);
    GvfSolveOptions o;
    o.mu = 0.2, o.tolerance = 0, o.iterations = 31;
    const Solution run = solve(s, o, 0);
    std::vector<std::vector<double>> ref;
    const double ref_residual = reference(s, run.stats.time_step, 31, ref);
    double diff = 0;
    for (int k = 0; k < s.K; ++k)
      for (size_t l = 0; l < ref[k].size(); ++l) diff = std::max(diff, std::abs(ref[k][l] - run.v[k][l]));
    EXPECT_LT(diff, 2e-6) << sh.nx << "x" << sh.ny << "x" << sh.nz;  // |v| <= 1, float rounding
    EXPECT_NEAR(run.stats.relative_residual, ref_residual, 1e-5 * ref_residual);
  }
}

// DDGVF runs its explicit solves side by side on the threads: an unstable step still comes out
// as the configuration error naming the key (not a crash in the parallel region).
TEST(GvfExplicitWavefront, DdgvfUnstableStepIsAnInputErrorOnTwoThreads) {
  Grid<3> grid;
  grid.size = GridIndex<3>(16, 16, 16);
  Image<3> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    image[l] = (grid.to_physical(grid.index(l)) - Point<3>(7.5, 7.5, 7.5)).norm() < 5 ? 1.f : 0.f;
  DdgvfFieldOptions o;
  o.solve.solver = GvfSolver::kExplicit, o.solve.time_step = 100.0, o.solve.iterations = 3, o.solve.tolerance = 0;
  const int saved = omp_get_max_threads();
  omp_set_num_threads(2);
  DdgvfField<3> field(o);
  try {
    field.compute(image);
    ADD_FAILURE() << "no error for an unstable step";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("time_step"), std::string::npos) << e.what();
  }
  omp_set_num_threads(saved);
}

}  // namespace
}  // namespace dsnake
