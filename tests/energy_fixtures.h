// Shared fixtures of the energy tests (tests/energies, tests/framework): wobbly test shapes, an
// energy made from its JSON spec, and seeded perturbations.
#pragma once

#include "energies/registry.h"
#include "experiments/phantoms/phantoms.h"
#include "framework/core/errors.h"
#include "framework/core/json_reader.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace dsnake::test_support {

// A closed n-gon with radius r(a) = radius (1 + 0.2 sin 3a + 0.1 cos 7a): no symmetry to hide behind.
inline Template<2> wobbly_polygon(int n, double radius = 10.0) {
  constexpr double kPi = 3.14159265358979323846;
  Template<2> t;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * kPi * i / n, r = radius * (1 + 0.2 * std::sin(3 * a) + 0.1 * std::cos(7 * a));
    t.positions.push_back(Point<2>(r * std::cos(a), r * std::sin(a)));
  }
  t.connectivity = Connectivity::polygon(n);
  return t;
}

// An icosphere scaled by radius (1 + 0.15 sin(3x + 2y) + 0.1 z^2) per vertex.
inline Template<3> wobbly_sphere(int subdivisions, double radius = 10.0) {
  Template<3> t = make_icosphere(subdivisions);
  for (auto& p : t.positions) p *= radius * (1 + 0.15 * std::sin(3 * p[0] + 2 * p[1]) + 0.1 * p[2] * p[2]);
  return t;
}

// The energy of a JSON spec, read as "energies[0]" of "test.json".
template <int D>
std::unique_ptr<Energy<D>> make_energy(const std::string& json) {
  const auto spec = nlohmann::json::parse(json);
  JsonReader r(spec, "test.json", "energies[0]");
  return energy_registry<D>().create(r);
}

// Each JSON spec is refused as an InputError at its JSON path ("energies[0].key").
template <int D>
void expect_refused_at(const std::vector<std::pair<const char*, const char*>>& cases) {
  for (const auto& [json, where] : cases) {
    SCOPED_TRACE(json);
    try {
      make_energy<D>(json);
      ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), where);
    }
  }
}

// The proposals of a fresh energy (make()) bound to `context`, at 1 and at 2 OpenMP threads,
// compared bit for bit (the thread count is restored).
template <int D, class Make>
void expect_same_proposals_at_one_and_two_threads(Make make, const EnergyContext<D>& context, const Snake<D>& snake) {
  const int threads = omp_get_max_threads();
  std::vector<PointList<D>> out;
  for (int k : {1, 2}) {
    omp_set_num_threads(k);
    auto energy = make();
    energy.bind(context, snake);
    out.emplace_back(snake.num_vertices());
    energy.propose(snake, out.back());
  }
  omp_set_num_threads(threads);
  for (int v = 0; v < snake.num_vertices(); ++v) EXPECT_EQ(out[0][v], out[1][v]) << v;
}

// p with every coordinate moved by a uniform amount in [-amount, amount], seeded.
template <int D>
PointList<D> perturbed(const PointList<D>& p, double amount, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amount, amount);
  PointList<D> q = p;
  for (auto& x : q)
    for (int a = 0; a < D; ++a) x[a] += u(rng);
  return q;
}

}  // namespace dsnake::test_support
