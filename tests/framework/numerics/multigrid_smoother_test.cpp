// The multigrid's smoother and grid transfers (framework/numerics/grid_diffusion_solver.cpp): several red-black
// Gauss-Seidel sweeps fused into one pass over memory give bit for bit the sweeps run one at a
// time, on 1 and 2 threads, and they are Gauss-Seidel: they match a voxel-by-voxel
// double-precision statement of red-black Gauss-Seidel for A v = rhs (A = diag(b) - mu
// Laplacian, zero flux). The x-row transfers equal linear interpolation P and P^T / 2 written
// out as dense matrices.
#include "framework/numerics/diffusion_grid.h"

#include <cmath>
#include <cstring>
#include <gtest/gtest.h>
#include <omp.h>
#include <random>
#include <string>

namespace dsnake {
namespace {

using gvf_detail::Coupling;
using gvf_detail::Level;

// A random system on nx x ny x nz (nz = 1: 2D) with spacing {1, 1.3, 2.5}: b in [0, 2),
// rhs in [-1, 1], v in [-0.5, 0.5], K fields.
Level random_level(int nx, int ny, int nz, int K, unsigned seed = 3) {
  Level L;
  L.nx = nx, L.ny = ny, L.nz = nz;
  L.h[0] = 1.0, L.h[1] = 1.3, L.h[2] = 2.5;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  L.b.resize(L.size());
  for (float& x : L.b) x = 2.f * unit(rng) * unit(rng);
  L.v.assign(K, std::vector<float>(L.size()));
  L.rhs.assign(K, std::vector<float>(L.size()));
  for (int k = 0; k < K; ++k)
    for (int64_t l = 0; l < L.size(); ++l) L.v[k][l] = unit(rng) - 0.5f, L.rhs[k][l] = 2.f * unit(rng) - 1.f;
  return L;
}

// Runs `sweeps` sweeps as one fused pass (fused) or one pass per sweep, on `threads` threads.
std::vector<std::vector<float>> smooth(Level L, int first, int sweeps, bool fused, int threads) {
  const Coupling c = gvf_detail::coupling(L, 0.2);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads);
  if (fused) {
    gvf_detail::smooth_sweeps(L, c, first, sweeps);
  } else {
    for (int s = 0; s < sweeps; ++s) gvf_detail::smooth_sweeps(L, c, first, 1);
  }
  omp_set_num_threads(saved);
  return L.v;
}

// Red-black Gauss-Seidel in double precision, voxel by voxel from the equations: voxels of
// colour (x + y + z) % 2 == colour get v = (rhs + sum over existing neighbours w v_nb) /
// (b + sum w), with w = mu / h_a^2; 2 sweeps x 2 colours starting with `first`.
std::vector<std::vector<double>> reference(const Level& L, int first, int sweeps) {
  const int n[3] = {L.nx, L.ny, L.nz};
  const int64_t stride[3] = {1, L.nx, int64_t(L.nx) * L.ny};
  std::vector<std::vector<double>> v(L.v.size());
  for (size_t k = 0; k < v.size(); ++k) v[k].assign(L.v[k].begin(), L.v[k].end());
  for (int half = 0; half < 2 * sweeps; ++half) {
    const int colour = (first + half) & 1;
    for (size_t k = 0; k < v.size(); ++k)
      for (int z = 0; z < L.nz; ++z)
        for (int y = 0; y < L.ny; ++y)
          for (int x = 0; x < L.nx; ++x) {
            if ((x + y + z) % 2 != colour) continue;
            const int idx[3] = {x, y, z};
            const int64_t l = x + stride[1] * y + stride[2] * z;
            double s = L.rhs[k][l], d = L.b[l];
            for (int a = 0; a < 3; ++a) {
              const double w = 0.2 / (L.h[a] * L.h[a]);
              if (idx[a] > 0) s += w * v[k][l - stride[a]], d += w;
              if (idx[a] < n[a] - 1) s += w * v[k][l + stride[a]], d += w;
            }
            v[k][l] = s / d;
          }
  }
  return v;
}

bool same_bits(const std::vector<std::vector<float>>& a, const std::vector<std::vector<float>>& b) {
  for (size_t k = 0; k < a.size(); ++k)
    if (std::memcmp(a[k].data(), b[k].data(), a[k].size() * sizeof(float)) != 0) return false;
  return true;
}

struct Shape {
  int nx, ny, nz;
};

TEST(GvfSmoother, FusedSweepsEqualSweepsOneAtATimeOnAnyThreadCount) {
  // Above the serial threshold (32768 voxels) so that two threads split the rows, with odd
  // sizes (vector loop plus scalar tail), a thin volume, and 2D.
  for (const Shape& sh : {Shape{53, 41, 19}, Shape{37, 29, 3}, Shape{211, 190, 1}, Shape{16, 5, 4}}) {
    const Level L = random_level(sh.nx, sh.ny, sh.nz, 3);
    for (int first : {0, 1}) {
      const auto one_at_a_time = smooth(L, first, 3, false, 1);
      for (int threads : {1, 2}) {
        EXPECT_TRUE(same_bits(one_at_a_time, smooth(L, first, 3, true, threads)))
            << sh.nx << "x" << sh.ny << "x" << sh.nz << " first " << first << " threads " << threads;
        EXPECT_TRUE(same_bits(one_at_a_time, smooth(L, first, 3, false, threads)))
            << sh.nx << "x" << sh.ny << "x" << sh.nz << " first " << first << " threads " << threads;
      }
    }
  }
}

// The cycle's pre-smoothing pass: starting from v = 0 without reading v (here full of NaN)
// gives bit for bit the sweeps from a zeroed v, on 1 and 2 threads.
TEST(GvfSmoother, ZeroStartEqualsSweepsFromAZeroedIterate) {
  for (const Shape& sh : {Shape{53, 41, 19}, Shape{211, 190, 1}, Shape{16, 5, 4}, Shape{9, 1, 1}}) {
    Level zeroed = random_level(sh.nx, sh.ny, sh.nz, 3);
    const Coupling c = gvf_detail::coupling(zeroed, 0.2);
    for (auto& vk : zeroed.v) std::fill(vk.begin(), vk.end(), 0.f);
    Level separate = zeroed;
    gvf_detail::smooth_sweeps(separate, c, 0, 2);
    for (int threads : {1, 2}) {
      Level fused = zeroed;
      for (auto& vk : fused.v) std::fill(vk.begin(), vk.end(), std::nanf(""));
      const int saved = omp_get_max_threads();
      omp_set_num_threads(threads);
      gvf_detail::smooth_sweeps(fused, c, 0, 2, true);
      omp_set_num_threads(saved);
      EXPECT_TRUE(same_bits(fused.v, separate.v)) << sh.nx << "x" << sh.ny << "x" << sh.nz << " threads " << threads;
    }
  }
}

// The cycle's restriction of the residual without a fine residual array gives bit
// for bit the residual rows followed by the restriction, on 1 and 2 threads, for every kind of
// axis: even (cell-centred), odd (vertex-centred) and not coarsened, in 3D, on one plane and on
// one row. The restriction itself is checked against P^T / 2 in the x-row tests below.
TEST(GvfSmoother, RestrictedResidualEqualsResidualThenRestriction) {
  struct Case {
    Shape fine;
    int factor[3];
  };
  const int f222[3] = {2, 2, 2}, f221[3] = {2, 2, 1}, f122[3] = {1, 2, 2};
  std::vector<Case> cases;
  for (const Shape& sh : {Shape{54, 41, 19}, Shape{47, 36, 20}, Shape{211, 190, 1}, Shape{33, 1, 1}})
    for (const int* f : {f222, f221, f122}) cases.push_back({sh, {f[0], sh.ny > 1 ? f[1] : 1, sh.nz > 1 ? f[2] : 1}});
  for (const Case& cs : cases) {
    Level F = random_level(cs.fine.nx, cs.fine.ny, cs.fine.nz, 2);
    const Coupling c = gvf_detail::coupling(F, 0.2);
    Level C;
    const int n[3] = {F.nx, F.ny, F.nz};
    int cn[3];
    for (int a = 0; a < 3; ++a) {
      F.factor[a] = cs.factor[a];
      cn[a] = F.factor[a] == 1 ? n[a] : (n[a] + 1) / 2;
    }
    C.nx = cn[0], C.ny = cn[1], C.nz = cn[2];
    const gvf_detail::Transfer t = gvf_detail::transfer(F, C);
    F.res.assign(2, std::vector<float>(F.size()));
    gvf_detail::residual_rows(F, c);
    const std::string name = std::to_string(F.nx) + "x" + std::to_string(F.ny) + "x" + std::to_string(F.nz) +
                             " factors " + std::to_string(F.factor[0]) + std::to_string(F.factor[1]) +
                             std::to_string(F.factor[2]);
    for (int k = 0; k < 2; ++k) {
      std::vector<float> want(C.size());
      gvf_detail::restrict_to(F, C, t, false, F.res[k].data(), want.data());
      for (int threads : {1, 2}) {
        std::vector<float> got(C.size(), std::nanf(""));
        const int saved = omp_get_max_threads();
        omp_set_num_threads(threads);
        gvf_detail::restrict_residual(F, c, C, t, k, got.data());
        omp_set_num_threads(saved);
        EXPECT_EQ(0, std::memcmp(got.data(), want.data(), want.size() * sizeof(float)))
            << name << " field " << k << " threads " << threads;
      }
    }
  }
}

TEST(GvfSmoother, SweepsAreRedBlackGaussSeidel) {
  for (const Shape& sh : {Shape{53, 41, 19}, Shape{211, 190, 1}, Shape{16, 5, 4}, Shape{1, 7, 3}, Shape{9, 1, 1}}) {
    const Level L = random_level(sh.nx, sh.ny, sh.nz, 2);
    for (int first : {0, 1}) {
      const auto got = smooth(L, first, 2, true, 2);
      const auto want = reference(L, first, 2);
      double diff = 0;
      for (size_t k = 0; k < got.size(); ++k)
        for (size_t l = 0; l < got[k].size(); ++l) diff = std::max(diff, std::abs(got[k][l] - want[k][l]));
      EXPECT_LT(diff, 1e-5) << sh.nx << "x" << sh.ny << "x" << sh.nz << " first " << first;  // |v| <~ 1
    }
  }
}

// Linear interpolation from n_coarse to n_fine nodes as a dense matrix: cell-centred (even
// n_fine: fine 2I and 2I + 1 sit at I -/+ 1/4, weights 3/4 and 1/4 to the nearest two coarse
// cells, clamped at the ends) or vertex-centred (odd: fine 2I is coarse I, 2I + 1 the mean).
std::vector<std::vector<double>> interpolation(int n_fine, int n_coarse) {
  std::vector<std::vector<double>> P(n_fine, std::vector<double>(n_coarse, 0.0));
  for (int i = 0; i < n_fine; ++i) {
    const int I = i / 2;
    if (n_fine % 2 == 0) {
      const int other = i % 2 == 0 ? std::max(I - 1, 0) : std::min(I + 1, n_coarse - 1);
      P[i][I] += 0.75, P[i][other] += 0.25;
    } else if (i % 2 == 0) {
      P[i][I] = 1.0;
    } else {
      P[i][I] = 0.5, P[i][I + 1] = 0.5;
    }
  }
  return P;
}

TEST(GvfTransfer, RowTransfersAreInterpolationAndItsTransposeOverTwo) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  for (int n_fine : {2, 3, 8, 9, 16, 17, 30, 31, 230}) {
    const int n_coarse = n_fine % 2 == 0 ? n_fine / 2 : (n_fine + 1) / 2;
    const auto P = interpolation(n_fine, n_coarse);
    const bool cell = n_fine % 2 == 0;
    // Prolongation: out += P coarse; ext repeats the coarse row's end values.
    std::vector<float> coarse(n_coarse), base(n_fine), ext(n_coarse + 2);
    for (float& x : coarse) x = unit(rng);
    for (float& x : base) x = unit(rng);
    std::copy(coarse.begin(), coarse.end(), ext.begin() + 1);
    ext[0] = coarse[0], ext[n_coarse + 1] = coarse[n_coarse - 1];
    std::vector<float> out = base;
    gvf_detail::prolongate_row_x2(out.data(), ext.data(), n_fine, n_coarse);
    for (int i = 0; i < n_fine; ++i) {
      double want = base[i];
      for (int I = 0; I < n_coarse; ++I) want += P[i][I] * coarse[I];
      EXPECT_NEAR(out[i], want, 1e-6) << "prolongation, n_fine " << n_fine << " i " << i;
    }
    // Restriction: out = P^T fine / 2; ext repeats the ends (cell-centred) or holds 0.
    std::vector<float> fine(n_fine), fext(n_fine + 2), res(n_coarse, 7.f);
    for (float& x : fine) x = unit(rng);
    std::copy(fine.begin(), fine.end(), fext.begin() + 1);
    fext[0] = cell ? fine[0] : 0.f, fext[n_fine + 1] = cell ? fine[n_fine - 1] : 0.f;
    gvf_detail::restrict_row_x2(res.data(), fext.data(), n_fine, n_coarse);
    for (int I = 0; I < n_coarse; ++I) {
      double want = 0;
      for (int i = 0; i < n_fine; ++i) want += P[i][I] * fine[i] / 2;
      EXPECT_NEAR(res[I], want, 1e-6) << "restriction, n_fine " << n_fine << " I " << I;
    }
  }
}

}  // namespace
}  // namespace dsnake
