// The grid diffusion solver: the linear system of gradient vector flow (Xu & Prince 1998; D-Snake
// §2), a framework engine shared by the GVF and DDGVF fields (fields/gvf.h, fields/ddgvf.h) and
// open to any plug-in that diffuses values over an image grid:
// for K fields v_k that share the weight b = |grad f|^2, find the fixed point of
//     mu Lap(v_k) - b (v_k - c_k) = 0,
// discretised on the image grid with the 2D+1-point Laplacian in physical units
// (sum over axes of (v[i-1] - 2v[i] + v[i+1]) / h_a^2) and zero flux at the border.
// Written as A v = b c with A = diag(b) - mu Lap (symmetric, positive semi-definite).
// Two solvers reach the same discrete fixed point:
//  - "explicit": Xu & Prince's iteration v += dt (mu Lap v - b (v - c)), the reference;
//  - "multigrid": conjugate gradients preconditioned by one multigrid W-cycle per iteration
//    (red-black Gauss-Seidel, coarsening the axes whose spacing is finest: semi-coarsening for
//    anisotropic voxels; exact dense solve on the coarsest grid).
// Both stop at a relative residual |b c - A v|_2 / |b c|_2 <= tolerance or after a number of
// iterations (explicit steps or PCG iterations). The multigrid solver takes the K fields one after another, each to
// |b c_k - A v_k| <= tolerance |b c_k| (which implies the joint test), so that its memory is
// that of one field. Float arrays (x fastest); OpenMP over z-slabs (2D: rows), and the
// explicit solver runs blocks of up to 10 iterations as a wavefront over tiles (each tile
// recomputes its halo, so the arrays stream from memory once per block); the results do not
// depend on the thread count (red-black updates are independent within a colour and
// every sum is accumulated per row, then in row order).
#pragma once

#include "framework/core/image.h"
#include "framework/core/options.h"

#include <memory>
#include <string>
#include <vector>

namespace dsnake {

// The two solvers above: kMultigrid ("multigrid", the default) and kExplicit ("explicit").
enum class GvfSolver { kMultigrid, kExplicit };
template <>
struct EnumNames<GvfSolver> {
  static constexpr std::array<std::pair<GvfSolver, const char*>, 2> table{
      {{GvfSolver::kMultigrid, "multigrid"}, {GvfSolver::kExplicit, "explicit"}}};
};

struct GvfSolveOptions {
  double mu = 0.2;          // diffusion weight (physical units: mm^2 per unit b)
  GvfSolver solver = GvfSolver::kMultigrid;
  double tolerance = 1e-4;  // relative residual to stop at; 0: run all iterations
  int iterations = 0;       // max iterations (explicit) or PCG iterations (multigrid); 0: 100000 / 100
  double time_step = 0.0;   // explicit only: 0 = 0.9 x the stability bound

  // JSON: "mu", "solver", "tolerance", "iterations", "time_step" (flattened into the field's object).
  template <class V>
  void visit(V& v) {
    v(mu, Key{"mu", "mm^2 per unit b", "diffusion weight of the GVF equation mu Lap v - b (v - c) = 0", Range::greater_than(0)});
    v(solver, Key{"solver", "", "multigrid-preconditioned conjugate gradients (default) or Xu & Prince's explicit iteration (the reference)"});
    v(tolerance, Key{"tolerance", "1 (relative residual)", "stop at |b c - A v| / |b c| <= tolerance (0: run all iterations)",
                     Range::closed_open(0, 1)});
    v(iterations, Key{"iterations", "iterations", "cap on explicit iterations or PCG iterations, one multigrid cycle each (0: 100000 / 100)",
                      Range::at_least(0)});
    v(time_step, Key{"time_step", "1 / unit of b", "explicit solver's step dt (0: 0.9 x the stability bound)",
                     Range::at_least(0)});
  }
  void check() const {
    if (tolerance == 0 && iterations == 0) throw OptionError{"iterations", "must be > 0 when tolerance is 0"};
  }
};

struct GvfSolveStats {
  int iterations = 0;              // explicit or PCG iterations done
  double relative_residual = 0.0;  // at the end (explicit: of the last iterate's update)
  double time_step = 0.0;          // explicit: the step used
};

// Memory a caller may keep across multigrid solves on one grid (DDGVF's 2D components): the
// hierarchy and the solver's vectors are then allocated (and paged in) once. Results are the
// same bits with or without it. One workspace per thread.
class GvfWorkspace {
 public:
  GvfWorkspace();
  ~GvfWorkspace();
  GvfWorkspace(const GvfWorkspace&) = delete;
  GvfWorkspace& operator=(const GvfWorkspace&) = delete;
  // The finest weights b of the last multigrid solve, handed back to the caller (empty if there
  // are none): DDGVF writes its next component's masked weights into them, so that each solve
  // does not page in a fresh volume-sized buffer. The hierarchy then needs new
  // weights, which the next solve gives it.
  std::vector<float> take_weights();
  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

// Solves for v (in: initial guess; out: solution), given b and the sources c (same sizes as the
// grid). b is taken by value: a caller that moves it in lets the solver keep it without a copy.
// Both solvers read c[k] only before v[k] changes (the explicit one copies b c into its own
// arrays first), so v[k] may be c[k]. Throws InputError naming "field.time_step" if an
// explicit step is unstable. The multigrid solver reuses `workspace` if given.
template <int D>
GvfSolveStats solve_gvf(const Grid<D>& grid, std::vector<float> b,
                        const std::vector<const std::vector<float>*>& c, const std::vector<std::vector<float>*>& v,
                        const GvfSolveOptions& options, GvfWorkspace* workspace = nullptr);

// Throws InputError naming "field.time_step" when an explicit step cannot be stable on `grid`,
// whatever the image: dt >= 2 / (4 mu sum_a 1/h_a^2), the bound with b = 0 (solve_gvf's own
// check adds the image's largest b and is tighter). Lets `dsnake validate` refuse such a step
// before the image is read; nothing to check for the multigrid solver or dt = 0.
template <int D>
void check_explicit_step(const Grid<D>& grid, const GvfSolveOptions& options);

// The relative residual |b c - A v|_2 / |b c|_2 (1 when b c = 0 and v != 0, 0 when both vanish).
template <int D>
double gvf_relative_residual(const Grid<D>& grid, const std::vector<float>& b,
                             const std::vector<const std::vector<float>*>& c,
                             const std::vector<const std::vector<float>*>& v, double mu);

}  // namespace dsnake
