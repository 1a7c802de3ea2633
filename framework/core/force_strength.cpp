// Force magnitudes of an external field; see force_strength.h.
#include "framework/core/force_strength.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace dsnake {

template <int D>
double max_force_magnitude(const ExternalField<D>& field) {
  if (const double told = told_largest_vector_norm(field); !std::isnan(told)) return told;
  const VectorField<D>& v = field.vectors();
  const int64_t n = v.num_voxels();
  double m2 = 0.0;  // max of squares: exact in any reduction order
#pragma omp parallel for reduction(max : m2) schedule(static) if (n >= (int64_t(1) << 16))
  for (int64_t i = 0; i < n; ++i) {
    const double s = v[i].squaredNorm();  // in double, from the stored floats
    if (std::isfinite(s)) m2 = std::max(m2, s);
  }
  return std::sqrt(m2);
}

template <int D>
double median_force_magnitude(const ExternalField<D>& field, const Snake<D>& snake) {
  const int n = snake.num_vertices();
  if (n == 0) return 0.0;
  PointList<D> normals;
  if (field.uses_normal()) snake.vertex_normals(normals);
  std::vector<double> m(n);
  const auto& q = snake.positions();
  for (int v = 0; v < n; ++v) {
    if (!q[v].allFinite()) return NAN;
    m[v] = field.force(q[v], field.uses_normal() ? normals[v] : Point<D>::Zero()).norm();
  }
  const size_t mid = m.size() / 2;
  std::nth_element(m.begin(), m.begin() + mid, m.end());
  if (m.size() % 2 == 1) return m[mid];
  const double upper = m[mid];
  return 0.5 * (upper + *std::max_element(m.begin(), m.begin() + mid));
}

template double max_force_magnitude(const ExternalField<2>&);
template double max_force_magnitude(const ExternalField<3>&);
template double median_force_magnitude(const ExternalField<2>&, const Snake<2>&);
template double median_force_magnitude(const ExternalField<3>&, const Snake<3>&);

}  // namespace dsnake
