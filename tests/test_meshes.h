// Closed test surfaces built in code for the remeshing tests and benchmark: an icosphere
// (genus 0), a torus (genus 1), a two-holed slab (genus 2) and a star-shaped sphere; and a
// closed polygon for the 2D stages.
#pragma once

#include "framework/core/shape.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

namespace dsnake::test {

// Icosahedron subdivided k times (midpoints pushed to the sphere), radius r: 10 * 4^k + 2 vertices.
inline Snake<3> icosphere(int k, double r = 1.0) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  PointList<3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Triangle> f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                             {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                             {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (auto& x : p) x.normalize();
  for (int s = 0; s < k; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      p.push_back((p[a] + p[b]).normalized());
      return mid[key] = static_cast<int>(p.size()) - 1;
    };
    std::vector<Triangle> g;
    for (const auto& t : f) {
      const int a = midpoint(t[0], t[1]), b = midpoint(t[1], t[2]), c = midpoint(t[2], t[0]);
      g.push_back({t[0], a, c});
      g.push_back({t[1], b, a});
      g.push_back({t[2], c, b});
      g.push_back({a, b, c});
    }
    f = std::move(g);
  }
  for (auto& x : p) x *= r;
  const int n = static_cast<int>(p.size());
  std::vector<int> ids(n);
  for (int v = 0; v < n; ++v) ids[v] = v;
  return Snake<3>(std::move(p), Connectivity::mesh(n, std::move(f)), std::move(ids));
}

// Torus with major radius R, minor radius r, nu x nv grid, each quad split in two.
inline Snake<3> torus(int nu, int nv, double R = 3.0, double r = 1.0) {
  PointList<3> p;
  std::vector<Triangle> f;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * std::numbers::pi * i / nu, v = 2 * std::numbers::pi * j / nv;
      p.push_back({(R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
    }
  auto id = [&](int i, int j) { return ((i + nu) % nu) * nv + (j + nv) % nv; };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      f.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      f.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  const int n = static_cast<int>(p.size());
  std::vector<int> ids(n);
  for (int v = 0; v < n; ++v) ids[v] = v;
  return Snake<3>(std::move(p), Connectivity::mesh(n, std::move(f)), std::move(ids));
}

// Genus 2: the boundary of a slab of 5s x 3s x s unit voxels with two s x s holes (at
// x in [s, 2s) and [3s, 4s), y in [s, 2s)), each boundary square split in two, outward.
inline Snake<3> two_hole_slab(int s = 2, double h = 1.0) {
  const int nx = 5 * s, ny = 3 * s, nz = s;
  auto solid = [&](int x, int y, int z) {
    if (x < 0 || y < 0 || z < 0 || x >= nx || y >= ny || z >= nz) return false;
    const bool hole_y = y >= s && y < 2 * s;
    return !(hole_y && ((x >= s && x < 2 * s) || (x >= 3 * s && x < 4 * s)));
  };
  std::map<std::array<int, 3>, int> index;
  PointList<3> p;
  auto vid = [&](int x, int y, int z) {
    auto [it, fresh] = index.emplace(std::array<int, 3>{x, y, z}, static_cast<int>(p.size()));
    if (fresh) p.push_back(Point<3>(x, y, z) * h);
    return it->second;
  };
  std::vector<Triangle> f;
  // For each solid voxel and each axis direction with an empty neighbour, the square face,
  // corners counter-clockwise seen from outside.
  for (int x = 0; x < nx; ++x)
    for (int y = 0; y < ny; ++y)
      for (int z = 0; z < nz; ++z) {
        if (!solid(x, y, z)) continue;
        for (int axis = 0; axis < 3; ++axis)
          for (int dir = -1; dir <= 1; dir += 2) {
            int n[3] = {x, y, z};
            n[axis] += dir;
            if (solid(n[0], n[1], n[2])) continue;
            const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
            std::array<int, 3> c0 = {x, y, z};
            if (dir > 0) c0[axis] += 1;
            auto corner = [&](int du, int dv) {
              std::array<int, 3> c = c0;
              c[a1] += du;
              c[a2] += dv;
              return vid(c[0], c[1], c[2]);
            };
            int q[4] = {corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)};
            if (dir < 0) std::swap(q[1], q[3]);
            f.push_back({q[0], q[1], q[2]});
            f.push_back({q[0], q[2], q[3]});
          }
      }
  const int n = static_cast<int>(p.size());
  std::vector<int> ids(n);
  for (int v = 0; v < n; ++v) ids[v] = v;
  return Snake<3>(std::move(p), Connectivity::mesh(n, std::move(f)), std::move(ids));
}

// A star-shaped sphere: icosphere(k) with radius 1 + a * sin(5 theta) sin(3 phi) style bumps.
inline Snake<3> star_sphere(int k, double amplitude = 0.25) {
  Snake<3> s = icosphere(k);
  PointList<3> q = s.positions();
  for (auto& x : q) {
    const double theta = std::atan2(x.y(), x.x()), phi = std::acos(std::clamp(x.z(), -1.0, 1.0));
    x *= 1 + amplitude * std::sin(5 * theta) * std::sin(phi) * std::sin(phi);
  }
  s.set_topology(std::move(q), s.connectivity(), s.template_ids());
  return s;
}

// Implicit surfaces f(x) = 0 (f < 0 inside, |grad f| about 1 near the surface), physical units:
// a torus about the z axis, and a genus-2 surface, the smooth union of two such tori side by
// side along x (centres at x = -+c, blended over k) whose inner tubes merge.
inline double torus_sdf(const Point<3>& x, double R, double r) {
  return std::hypot(std::hypot(x.x(), x.y()) - R, x.z()) - r;
}
inline double genus2_sdf(const Point<3>& x, double R = 12, double r = 5, double c = 14, double k = 4) {
  const double a = torus_sdf(x - Point<3>(-c, 0, 0), R, r), b = torus_sdf(x - Point<3>(c, 0, 0), R, r);
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k / 4;
}
// The gradient of f by central differences of step h.
template <class F>
Point<3> implicit_gradient(const F& f, const Point<3>& x, double h = 1e-4) {
  Point<3> g;
  for (int k = 0; k < 3; ++k) {
    const Point<3> e = Point<3>::Unit(k) * h;
    g[k] = (f(x + e) - f(x - e)) / (2 * h);
  }
  return g;
}
// One Newton step of x towards f = 0 along the gradient: x - f grad f / |grad f|^2.
template <class F>
Point<3> towards_surface(const F& f, const Point<3>& x) {
  const Point<3> g = implicit_gradient(f, x);
  const double g2 = g.squaredNorm();
  return g2 > 0 ? Point<3>(x - f(x) / g2 * g) : x;
}

// A genus-2 template for genus2_sdf's default surface: two_hole_slab(s) centred, scaled onto
// the surface's extent (holes over the holes) and projected onto it by a few Newton steps.
inline Snake<3> genus2_template(int s = 2) {
  Snake<3> slab = two_hole_slab(s, 1.0);
  PointList<3> q = slab.positions();
  const double scale = 12.4 / s;  // hole centres at x = -+2 s (slab units) -> -+12.4 (near -+14)
  auto f = [](const Point<3>& x) { return genus2_sdf(x); };
  for (auto& x : q) {
    x = Point<3>((x.x() - 2.5 * s) * scale, (x.y() - 1.5 * s) * scale, (x.z() - 0.5 * s) * 10.0 / s);
    for (int i = 0; i < 8; ++i) x = towards_surface(f, x);
  }
  slab.set_topology(std::move(q), slab.connectivity(), slab.template_ids());
  return slab;
}

// Marks every vertex whose index is not a multiple of `keep_every` as free (template id -1),
// so that the remeshers have free vertices to move and collapse; the rest keep their ids.
inline Snake<3> with_free_vertices(const Snake<3>& s, int keep_every) {
  std::vector<int> ids = s.template_ids();
  for (size_t v = 0; v < ids.size(); ++v)
    if (v % keep_every != 0) ids[v] = -1;
  return Snake<3>(s.positions(), s.connectivity(), std::move(ids));
}

// An ellipse with semi-axes a and b as a closed counter-clockwise polygon of n vertices, spaced
// unevenly (the parameter t_k = 2 pi k / n + 0.3 sin(2 pi k / n)), every `keep_every`-th a
// deformation vertex (template id k), the others free.
inline Snake<2> uneven_ellipse(int n, double a = 20.0, double b = 10.0, int keep_every = 4) {
  PointList<2> q;
  std::vector<int> ids;
  for (int k = 0; k < n; ++k) {
    const double u = 2 * std::numbers::pi * k / n, t = u + 0.3 * std::sin(u);
    q.push_back(Point<2>(a * std::cos(t), b * std::sin(t)));
    ids.push_back(k % keep_every == 0 ? k : -1);
  }
  return Snake<2>(std::move(q), Connectivity::polygon(n), std::move(ids));
}

}  // namespace dsnake::test
