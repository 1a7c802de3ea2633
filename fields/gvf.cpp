// Gradient vector flow field; see gvf.h (Xu & Prince 1998; D-Snake §2).
#include "fields/gvf.h"

#include "fields/field_state.h"
#include "framework/core/errors.h"

namespace dsnake {

template <int D>
GvfField<D>::GvfField(const GvfFieldOptions& options) : options_(checked(options, kType)) {}

// Memory: the sources grad f are solved in place (they are the initial guess, and
// both solvers read a source only before its field changes), f is released before the solve, b
// is moved into the solver, and the stored vectors are allocated after it, so the peak is b, the
// three components and one component's solver arrays (and the image, unless compute_releasing).
template <int D>
void GvfField<D>::compute(const Image<D>& image) {
  solve(compute_edge_map(image, options_.edge, false, "gvf"));
}

template <int D>
void GvfField<D>::compute_releasing(Image<D>&& image) {
  solve(compute_edge_map(std::move(image), options_.edge, false, "gvf"));
}

template <int D>
void GvfField<D>::solve(EdgeMap<D>&& edges) {
  const Grid<D> grid = edges.grid;
  const int64_t n = grid.num_voxels();
  vectors_ = VectorField<D>();
  stats_ = {};
  if (edges.f_max == 0) {  // no edges: the zero field (warned by compute_edge_map)
    vectors_ = VectorField<D>(grid);
    return;
  }
  std::vector<float>().swap(edges.f);
  // b = |grad f|^2; the sources c = grad f are also the initial guess (Xu & Prince).
  std::vector<float> b(n);
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    float s = 0;
    for (int a = 0; a < D; ++a) s += edges.grad_f[a][l] * edges.grad_f[a][l];
    b[l] = s;
  }
  std::vector<const std::vector<float>*> c;
  std::vector<std::vector<float>*> out;
  for (int a = 0; a < D; ++a) c.push_back(&edges.grad_f[a]), out.push_back(&edges.grad_f[a]);
  stats_ = solve_gvf(grid, std::move(b), c, out, options_.solve);
  vectors_ = VectorField<D>(grid);
  for (int a = 0; a < D; ++a) {
    const std::vector<float>& v = *out[a];
#pragma omp parallel for schedule(static)
    for (int64_t l = 0; l < n; ++l) vectors_[l][a] = v[l];
    std::vector<float>().swap(*out[a]);
  }
}

template <int D>
Point<D> GvfField<D>::force(const Point<D>& x, const Point<D>&) const {
  DSNAKE_ASSERT(!vectors_.empty(), "compute() before force()");
  return vectors_.sample(x);
}

template <int D>
std::string GvfField<D>::save_state() const {
  StateWriter w("dsnake-gvf-2");
  w.grid(vectors_.grid());
  w.value(stats_);
  w.vectors(vectors_);
  return std::move(w).bytes();
}

template <int D>
bool GvfField<D>::load_state(const Grid<D>& grid, const std::string& bytes) {
  StateReader r(bytes, "dsnake-gvf-2");
  if (!r.grid(grid)) return false;
  const GvfSolveStats stats = r.value<GvfSolveStats>();
  VectorField<D> v = r.vectors(grid);
  if (!r.ok()) return false;
  stats_ = stats, vectors_ = std::move(v);
  return true;
}

template class GvfField<2>;
template class GvfField<3>;

}  // namespace dsnake
