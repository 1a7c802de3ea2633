// Xu & Prince's explicit GVF iteration (1998), the reference solver; see gvf_solver.h.
#include "fields/gvf_grid.h"

#include "framework/errors.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace dsnake::gvf_detail {

namespace {

// One explicit step on a row of one field: out = u + dt (mu Lap u - b (u - c)); with `measure`,
// also acc += |mu Lap u - b (u - c)|^2 in index order (a scalar loop, so that the sum does not
// depend on vector width or threads). End voxels of the row have one x neighbour.
DSNAKE_VECTOR_CLONES
void explicit_row(const float* u, const float* c, float* next, const float* __restrict b, const RowNeighbours& r,
             float cx, float dt, int nx, bool measure, float& acc) {
  const float* __restrict src = c + r.row;
  const float *__restrict u0 = u + r.row, *__restrict uym = u + r.ym, *__restrict uyp = u + r.yp,
              *__restrict uzm = u + r.zm, *__restrict uzp = u + r.zp;
  float* __restrict out = next + r.row;
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
  // and is not inlined into this function's AVX2 clone, which then does not vectorise.
  const float diag = side + 2.f * cx;
  if (measure) {
    acc += e0 * e0;
    for (int i = 1; i < nx - 1; ++i) {
      const float e = cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] -
                      (diag + b[i]) * u0[i] + b[i] * src[i];
      out[i] = u0[i] + dt * e;
      acc += e * e;
    }
    acc += e1 * e1;
  } else {
    for (int i = 1; i < nx - 1; ++i) {
      const float e = cx * (u0[i - 1] + u0[i + 1]) + wym * uym[i] + wyp * uyp[i] + wzm * uzm[i] + wzp * uzp[i] -
                      (diag + b[i]) * u0[i] + b[i] * src[i];
      out[i] = u0[i] + dt * e;
    }
  }
}

}  // namespace

// Xu & Prince's explicit iteration: v_new = v + dt (mu Lap v - b (v - c)), double-buffered.
GvfSolveStats solve_explicit(Level& L, const std::vector<const std::vector<float>*>& c,
                             const std::vector<std::vector<float>*>& v, const GvfSolveOptions& o, double rhs_norm2) {
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
  const int K = int(v.size()), nx = L.nx;
  const int64_t rows = int64_t(L.ny) * L.nz;
  const int max_it = o.iterations > 0 ? o.iterations : 100000;
  const float dt = float(st.time_step);
  std::vector<std::vector<float>> next(K, std::vector<float>(L.size()));
  std::vector<double> row_sum(rows);
  // The residual (= update / dt) is measured every kCheckEvery iterations and at the last one.
  constexpr int kCheckEvery = 10;
  for (int it = 0; it < max_it; ++it) {
    const bool measure = it + 1 == max_it || (o.tolerance > 0 && (it + 1) % kCheckEvery == 0);
#pragma omp parallel for schedule(static) if(L.size() >= kParallelMin)
    for (int64_t yz = 0; yz < rows; ++yz) {
      const RowNeighbours r = row_neighbours(L, cp, int(yz % L.ny), int(yz / L.ny));
      const float* b = L.b.data() + r.row;
      double s2 = 0;
      for (int k = 0; k < K; ++k) {
        float acc = 0.f;
        explicit_row(v[k]->data(), c[k]->data(), next[k].data(), b, r, cp.cx, dt, nx, measure, acc);
        s2 += acc;
      }
      row_sum[yz] = s2;
    }
    for (int k = 0; k < K; ++k) v[k]->swap(next[k]);
    st.iterations = it + 1;
    if (!measure) continue;
    double s = 0;
    for (int64_t yz = 0; yz < rows; ++yz) s += row_sum[yz];
    st.relative_residual = rhs_norm2 > 0 ? std::sqrt(s / rhs_norm2) : (s > 0 ? 1.0 : 0.0);
    if (o.tolerance > 0 && st.relative_residual <= o.tolerance) break;
  }
  return st;
}


}  // namespace dsnake::gvf_detail
