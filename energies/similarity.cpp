// The global similarity term; see similarity.h. Umeyama, "Least-squares estimation of
// transformation parameters between two point patterns" (PAMI 1991): for centred data a_i = p_i - p*
// and b_i = q_i - q*, S*(x) = q* + M (x - p*) with M = mu R, R the proper rotation maximising
// trace(R^T sum b a^T) and mu = trace(R^T sum b a^T) / sum |a|^2 (mu = 1 for a rigid motion).
#include "energies/similarity.h"

#include "energies/mls_weights.h"
#include "framework/core/errors.h"

namespace dsnake {

template <int D>
struct SimilarityEnergy<D>::Data {
  const Template<D>* tmpl = nullptr;
  int n = 0;
  PointList<D> a;        // per template id: p_i - p*
  Point<D> p_centroid = Point<D>::Zero();
  double spread = 0.0;   // sum |a_i|^2
  std::vector<int> vertex_of_id;
  int bound_vertices = -1;  // the snake's vertex count and topology version at the last bind
  uint64_t bound_version = 0;
};

template <int D>
SimilarityEnergy<D>::SimilarityEnergy(const SimilarityOptions& options)
    : options_(checked(options, kType)), data_(std::make_unique<Data>()) {}

template <int D>
SimilarityEnergy<D>::~SimilarityEnergy() = default;

template <int D>
void SimilarityEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  Data& d = *data_;
  const Template<D>* tmpl = context.tmpl ? context.tmpl : d.tmpl;
  DSNAKE_ASSERT(tmpl != nullptr, "similarity is bound to a template");
  if (tmpl != d.tmpl || tmpl->num_vertices() != d.n) {
    d.tmpl = tmpl;
    d.n = tmpl->num_vertices();
    d.p_centroid = Point<D>::Zero();
    for (const auto& p : tmpl->positions) d.p_centroid += p;
    if (d.n > 0) d.p_centroid /= d.n;
    d.a.resize(d.n);
    d.spread = 0.0;
    for (int i = 0; i < d.n; ++i) {
      d.a[i] = tmpl->positions[i] - d.p_centroid;
      d.spread += d.a[i].squaredNorm();
    }
  }
  map_template_vertices(snake, d.n, d.vertex_of_id);
  d.bound_vertices = snake.num_vertices();
  d.bound_version = snake.topology_version();
}

// S*(x) = q* + M (x - p*) for the current positions (serial sums: the same on any thread count).
template <int D>
static void fit(const PointList<D>& a, double spread, bool rigid, const PointList<D>& positions,
                const std::vector<int>& vertex_of_id, Point<D>& q_centroid, Eigen::Matrix<double, D, D>& m) {
  const int n = int(a.size());
  q_centroid = Point<D>::Zero();
  for (int i = 0; i < n; ++i) q_centroid += positions[vertex_of_id[i]];
  if (n > 0) q_centroid /= n;
  Eigen::Matrix<double, D, D> cross = Eigen::Matrix<double, D, D>::Zero();
  for (int i = 0; i < n; ++i) cross.noalias() += (positions[vertex_of_id[i]] - q_centroid) * a[i].transpose();
  m = rigid ? best_rotation<D>(cross) : best_similarity<D>(cross, spread);
}

template <int D>
void SimilarityEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before propose()");
  DSNAKE_ASSERT(d.bound_vertices == snake.num_vertices() && d.bound_version == snake.topology_version(),
                "bound to the snake's topology (the phase driver rebinds after a remesh)");
  Point<D> centroid;
  Eigen::Matrix<double, D, D> m;
  fit<D>(d.a, d.spread, options_.transform == SimilarityTransform::kRigid, snake.positions(), d.vertex_of_id, centroid, m);
  for (int i = 0; i < d.n; ++i) out[d.vertex_of_id[i]] = centroid + m * d.a[i];
}

template <int D>
double SimilarityEnergy<D>::value(const Snake<D>& snake) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.tmpl != nullptr, "bind() before value()");
  std::vector<int> vertex_of_id;
  map_template_vertices(snake, d.n, vertex_of_id);
  Point<D> centroid;
  Eigen::Matrix<double, D, D> m;
  fit<D>(d.a, d.spread, options_.transform == SimilarityTransform::kRigid, snake.positions(), vertex_of_id, centroid, m);
  double e = 0.0;
  for (int i = 0; i < d.n; ++i) e += (centroid + m * d.a[i] - snake.positions()[vertex_of_id[i]]).squaredNorm();
  return e;
}

template class SimilarityEnergy<2>;
template class SimilarityEnergy<3>;

}  // namespace dsnake
