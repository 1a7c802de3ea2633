// Discrete operators on a snake's connectivity; see mesh_operators.h.
#include "framework/operators/mesh_operators.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace dsnake {

template <int D>
Point<D> one_ring_mean(const Connectivity& c, const PointList<D>& q, int v) {
  const auto ring = c.neighbors(v);
  Point<D> mean = Point<D>::Zero();
  for (int w : ring) mean += q[w];
  mean /= double(ring.size());
  return mean;
}

template <int D>
Point<D> umbrella_laplacian(const Connectivity& c, const PointList<D>& q, int v) {
  if (c.neighbors(v).empty()) return Point<D>::Zero();
  return q[v] - one_ring_mean<D>(c, q, v);
}

double umbrella_weight(const Connectivity& c, int v) {
  const auto ring = c.neighbors(v);
  return ring.empty() ? 1.0 : static_cast<double>(ring.size());
}

Eigen::SparseMatrix<double> combinatorial_laplacian(const Connectivity& c) {
  const int n = c.num_vertices();
  std::vector<Eigen::Triplet<double>> entries;
  for (int v = 0; v < n; ++v) {
    const auto ring = c.neighbors(v);
    entries.emplace_back(v, v, static_cast<double>(ring.size()));
    for (int w : ring) entries.emplace_back(v, w, -1.0);
  }
  Eigen::SparseMatrix<double> lc(n, n);
  lc.setFromTriplets(entries.begin(), entries.end());
  return lc;
}

template <int D>
std::vector<int> element_vertices(const Connectivity& c) {
  std::vector<int> vertices;
  if constexpr (D == 2) {
    const int n = c.num_vertices();
    for (int v = 0; v < n; ++v) vertices.insert(vertices.end(), {v, (v + 1) % n});
  } else {
    for (const Triangle& t : c.triangles()) vertices.insert(vertices.end(), {t[0], t[1], t[2]});
  }
  return vertices;
}

template <int D>
double element_measure_floor(const PointList<D>& q, const std::vector<int>& elements) {
  double sum = 0;
  const size_t count = elements.size();
  for (size_t e = 0; e < count; e += D)
    for (int a = 0; a < D; ++a) sum += (q[elements[e + (a + 1) % D]] - q[elements[e + a]]).norm();
  const double mean = count > 0 ? sum / double(count) : 0.0;
  const double floor = D == 2 ? kRelativeMeasureFloor * mean : kRelativeMeasureFloor * mean * mean;
  return floor > 0 && std::isfinite(floor) ? floor : 1.0;
}

void triangle_edges(const PointList<3>& q, const int* t, double floor, Point<3> (&e)[3], double& area) {
  e[0] = q[t[2]] - q[t[1]];
  e[1] = q[t[0]] - q[t[2]];
  e[2] = q[t[1]] - q[t[0]];
  area = std::max(0.5 * e[1].cross(e[2]).norm(), floor);
}

void mixed_voronoi_areas(const Point<3> (&e)[3], double area, double (&part)[3]) {
  // dot[i] = (q_j - q_i) . (q_l - q_i), twice the area times cot(angle i)
  const double dot[3] = {-e[1].dot(e[2]), -e[2].dot(e[0]), -e[0].dot(e[1])};
  const bool obtuse = dot[0] < 0 || dot[1] < 0 || dot[2] < 0;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, l = (i + 2) % 3;
    if (obtuse)
      part[i] = dot[i] < 0 ? 0.5 * area : 0.25 * area;
    else
      part[i] = (e[l].squaredNorm() * dot[l] + e[j].squaredNorm() * dot[j]) / (16.0 * area);
  }
}

template <int D>
void element_stiffness_and_mass(const PointList<D>& q, const std::vector<int>& elements, std::vector<double>& local,
                                std::vector<double>& mass, bool with_mass) {
  const double floor = element_measure_floor<D>(q, elements);
  const size_t count = elements.size() / D;
  local.resize(count * D * D);
  mass.assign(with_mass ? q.size() : 0, 0.0);
  for (size_t e = 0; e < count; ++e) {
    const int* v = elements.data() + e * D;
    double* k = local.data() + e * D * D;
    if constexpr (D == 2) {
      const double length = std::max((q[v[1]] - q[v[0]]).norm(), floor), w = 1.0 / length;
      k[0] = k[3] = w;
      k[1] = k[2] = -w;
      if (with_mass) mass[v[0]] += 0.5 * length, mass[v[1]] += 0.5 * length;
    } else {
      Point<3> edge[3];
      double area = 0, part[3];
      triangle_edges(q, v, floor, edge, area);
      if (with_mass) {
        mixed_voronoi_areas(edge, area, part);
        for (int i = 0; i < 3; ++i) mass[v[i]] += part[i];
      }
      const double scale = 1.0 / (4.0 * area);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) k[3 * i + j] = scale * edge[i].dot(edge[j]);
    }
  }
  for (double& m : mass) m = std::max(m, floor);  // NaN-free M^-1, also for a vertex in no element
}

template <int D>
Eigen::SparseMatrix<double> stiffness_matrix(const Snake<D>& snake, const std::vector<int>& elements,
                                             std::vector<double>& mass) {
  std::vector<double> local;
  element_stiffness_and_mass<D>(snake.positions(), elements, local, mass);
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(local.size());
  for (size_t e = 0; e < elements.size() / D; ++e)
    for (int i = 0; i < D; ++i)
      for (int j = 0; j < D; ++j) entries.emplace_back(elements[e * D + i], elements[e * D + j], local[e * D * D + D * i + j]);
  const int n = snake.num_vertices();
  Eigen::SparseMatrix<double> k(n, n);
  k.setFromTriplets(entries.begin(), entries.end());
  return k;
}

template Point<2> one_ring_mean<2>(const Connectivity&, const PointList<2>&, int);
template Point<3> one_ring_mean<3>(const Connectivity&, const PointList<3>&, int);
template Point<2> umbrella_laplacian<2>(const Connectivity&, const PointList<2>&, int);
template Point<3> umbrella_laplacian<3>(const Connectivity&, const PointList<3>&, int);
template std::vector<int> element_vertices<2>(const Connectivity&);
template std::vector<int> element_vertices<3>(const Connectivity&);
template double element_measure_floor<2>(const PointList<2>&, const std::vector<int>&);
template double element_measure_floor<3>(const PointList<3>&, const std::vector<int>&);
template void element_stiffness_and_mass<2>(const PointList<2>&, const std::vector<int>&, std::vector<double>&,
                                             std::vector<double>&, bool);
template void element_stiffness_and_mass<3>(const PointList<3>&, const std::vector<int>&, std::vector<double>&,
                                             std::vector<double>&, bool);
template Eigen::SparseMatrix<double> stiffness_matrix<2>(const Snake<2>&, const std::vector<int>&, std::vector<double>&);
template Eigen::SparseMatrix<double> stiffness_matrix<3>(const Snake<3>&, const std::vector<int>&, std::vector<double>&);

}  // namespace dsnake
