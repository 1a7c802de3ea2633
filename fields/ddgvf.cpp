// Dynamic directional GVF; see ddgvf.h.
//
// How we read Cheng & Foo (2006) and D-Snake §2.1. With the blurred image I_s = G_sigma * I,
// the edge map f = |grad I_s|^2 and the GVF weight b = |grad f|^2, an edge's normal is the
// direction of grad I_s there ("the direction of the gradient is the direction of the normal to
// the edge"). For each axis a and sign s in {+, -}, let
//     m_{a,s}(x) = 1 if s p dI_s/dx_a (x) > 0, else 0,
// with p = +1 for "dark_inside" (I grows along the outward normal) and p = -1 for
// "bright_inside". The directional component u_{a,s} is the scalar GVF of the masked edge force:
//     mu Lap u_{a,s} - b m_{a,s} (u_{a,s} - m_{a,s} df/dx_a) = 0,
// i.e. the edges of the other polarity along axis a are invisible to it (no source and no
// weight: u_{a,s} diffuses through them as through flat image). A vertex with outward normal n
// feels, along each axis, the component whose polarity agrees with its normal:
//     F(x, n)_a = u_{a, sign(n_a)}(x),   sign(0) = +.
// So "a vertex is attracted to edges consistent with its own normal ... blind to edges for
// which none of their normal components agrees with its own" (§2.1); it still moves in any
// direction (this is not a balloon force). We solve the 2D scalar problems with the GVF solver
// (framework/numerics/grid_diffusion_solver.h), so the solver choice and tolerance are the same as for "gvf".
#include "fields/ddgvf.h"

#include "fields/field_state.h"
#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <mutex>
#include <omp.h>

namespace dsnake {

template <int D>
DdgvfField<D>::DdgvfField(const DdgvfFieldOptions& options) : options_(checked(options, kType)) { reset_vectors(); }

template <int D>
void DdgvfField<D>::compute(const Image<D>& image) {
  solve(compute_edge_map(image, options_.edge, true, "ddgvf"));
}

template <int D>
void DdgvfField<D>::compute_releasing(Image<D>&& image) {
  solve(compute_edge_map(std::move(image), options_.edge, true, "ddgvf"));
}

// Memory: b is written over f (DDGVF does not use f); the image gradient is kept as
// its signs (a byte per voxel); each multigrid solve starts from its masked source written
// straight into its component (the solver reads a source only before its field changes) and
// takes its masked weights by move, written into the previous solve's weights
// (GvfWorkspace::take_weights: no fresh pages per solve). A component is allocated when its
// solve starts, and the second solve of an axis masks grad f_a in place and keeps its buffer as
// its component: the edge map's gradient and the components are never more than 2 D volumes
// together. The summed vectors are made only when asked for (vectors()).
template <int D>
void DdgvfField<D>::solve(EdgeMap<D>&& edges) {
  const Grid<D> grid = edges.grid;
  const int64_t n = grid.num_voxels();
  reset_vectors();
  for (auto& axis : components_)
    for (auto& c : axis) c = Image<D>();
  if (edges.f_max == 0) {  // no edges: zero components (warned by compute_edge_map)
    for (auto& axis : components_)
      for (auto& c : axis) c = Image<D>(grid);
    return;
  }
  std::vector<float> b = std::move(edges.f);  // f's pages hold b (no fresh buffer to page in)
  b.resize(n);
  const unsigned p = options_.polarity == DdgvfPolarity::kDarkInside ? 0u : 1u;
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    float s = 0;
    for (int a = 0; a < D; ++a) s += edges.grad_f[a][l] * edges.grad_f[a][l];
    b[l] = s;
  }
  // The 2 D scalar solves are independent: with several threads they run side by side, each on
  // one thread (a solve's result does not depend on its thread count), which avoids the
  // per-sweep synchronisation of splitting each solve. An exception (a bad explicit time step)
  // cannot leave a parallel region: it is kept and rethrown after it. Per axis, the first job to
  // take the axis's lock copies its masked source out of grad f_a; the second masks grad f_a in
  // place once the first has read it (the lock orders the two) and takes it as its component.
  const int threads = std::min(omp_get_max_threads(), 2 * D);
  std::vector<std::exception_ptr> errors(2 * D);
  std::array<omp_lock_t, D> axis_lock;
  std::array<int, D> sources_made{};
  for (auto& lock : axis_lock) omp_init_lock(&lock);
  const std::vector<uint8_t>& signs = edges.gradient_signs;
#pragma omp parallel num_threads(threads) if(threads > 1)
  {
    GvfWorkspace workspace;  // this thread's solves share one multigrid hierarchy
#pragma omp for schedule(dynamic, 1)
    for (int job = 0; job < 2 * D; ++job) {
      const int a = job / 2, sign = job % 2;
      // "on" where s p dI/dx_a > 0 (ddgvf.cpp's header): the sign bit of axis a that agrees.
      const unsigned bit = 1u << (2 * a + (unsigned(sign) ^ p));
      std::vector<float> u;  // the initial guess is the source, as for GVF
      omp_set_lock(&axis_lock[a]);
      std::vector<float>& g = edges.grad_f[a];
      if (sources_made[a] == 0) {
        u.resize(n);
        for (int64_t l = 0; l < n; ++l) u[l] = (signs[l] & bit) ? g[l] : 0.f;
      } else {
        for (int64_t l = 0; l < n; ++l)
          if (!(signs[l] & bit)) g[l] = 0.f;
        u = std::move(g);
      }
      ++sources_made[a];
      omp_unset_lock(&axis_lock[a]);
      std::vector<float> b_masked = workspace.take_weights();  // the last solve's pages, if any
      b_masked.resize(n);
      for (int64_t l = 0; l < n; ++l) b_masked[l] = (signs[l] & bit) ? b[l] : 0.f;
      try {
        solve_gvf(grid, std::move(b_masked), {&u}, {&u}, options_.solve, &workspace);
      } catch (...) {
        errors[job] = std::current_exception();
      }
      components_[a][sign] = Image<D>(grid, std::move(u));
    }
  }
  for (auto& lock : axis_lock) omp_destroy_lock(&lock);
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

// The polarity-blind sum of both signs per axis, made on first use (figures, `dsnake field`, the
// force's largest magnitude): a run that only samples forces never holds these D volumes.
template <int D>
const VectorField<D>& DdgvfField<D>::vectors() const {
  std::call_once(*vectors_made_, [this] {
    const Grid<D>& grid = components_[0][0].grid();
    const int64_t n = grid.num_voxels();
    VectorField<D> v(grid);
#pragma omp parallel for schedule(static)
    for (int64_t l = 0; l < n; ++l)
      for (int a = 0; a < D; ++a) v.at(l)[a] = summed(a, l);
    vectors_ = std::move(v);
  });
  return vectors_;
}

template <int D>
double DdgvfField<D>::largest_vector_norm() const {
  const int64_t n = num_voxels();
  double m2 = 0.0;  // max of squares: exact in any reduction order (as max_force_magnitude)
#pragma omp parallel for reduction(max : m2) schedule(static) if (n >= (int64_t(1) << 16))
  for (int64_t l = 0; l < n; ++l) {
    Point<D> f;  // vectors()'s floats, in double, summed as VectorField's squaredNorm sums them
    for (int a = 0; a < D; ++a) f[a] = summed(a, l);
    const double s = f.squaredNorm();
    if (std::isfinite(s)) m2 = std::max(m2, s);
  }
  return std::sqrt(m2);
}

template <int D>
void DdgvfField<D>::reset_vectors() {
  vectors_ = VectorField<D>();
  vectors_made_ = std::make_unique<std::once_flag>();
}

template <int D>
Point<D> DdgvfField<D>::force(const Point<D>& x, const Point<D>& normal) const {
  DSNAKE_ASSERT(!components_[0][0].data().empty(), "compute() before force()");
  const auto stencil = components_[0][0].grid().stencil(x);
  Point<D> f;
  for (int a = 0; a < D; ++a) {
    const Image<D>& u = components_[a][normal[a] >= 0 ? 0 : 1];
    double s = 0;
    for (size_t k = 0; k < stencil.voxel.size(); ++k) s += stencil.weight[k] * u[stencil.voxel[k]];
    f[a] = s;
  }
  return f;
}

template <int D>
void DdgvfField<D>::prefetch(const Point<D>& x, const Point<D>& normal) const {
  if (components_[0][0].data().empty()) return;
  const auto stencil = components_[0][0].grid().stencil(x);
  for (int a = 0; a < D; ++a) {
    const float* u = components_[a][normal[a] >= 0 ? 0 : 1].data().data();
    // The stencil's voxels come in pairs along x (one line, or two when the pair straddles one).
    for (size_t k = 0; k < stencil.voxel.size(); k += 2) {
      __builtin_prefetch(u + stencil.voxel[k]);
      __builtin_prefetch(u + stencil.voxel[k + 1]);
    }
  }
}

template <int D>
std::string DdgvfField<D>::save_state() const {
  StateWriter w("dsnake-ddgvf-2");
  w.grid(components_[0][0].grid());
  for (const auto& axis : components_)
    for (const auto& c : axis) w.array(c.data());
  return std::move(w).bytes();
}

template <int D>
bool DdgvfField<D>::load_state(const Grid<D>& grid, const std::string& bytes) {
  StateReader r(bytes, "dsnake-ddgvf-2");
  if (!r.grid(grid)) return false;
  std::array<std::array<Image<D>, 2>, D> comps;
  for (auto& axis : comps)
    for (auto& c : axis) {
      std::vector<float> a = r.array<float>();
      if (int64_t(a.size()) != grid.num_voxels()) return false;
      c = Image<D>(grid, std::move(a));
    }
  if (!r.ok()) return false;
  components_ = std::move(comps);
  reset_vectors();
  return true;
}

template class DdgvfField<2>;
template class DdgvfField<3>;

}  // namespace dsnake
