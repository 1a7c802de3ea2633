// InternalEnergy: the Kass step against dense solves, the value's gradient against finite
// differences, symmetry invariants on regular shapes, rebinding after a topology change; and the
// energy registry's error messages.
#include "energies/internal.h"
#include "energies/registry.h"
#include "experiments/phantoms/phantoms.h"
#include "framework/core/errors.h"

#include <Eigen/Dense>
#include <cmath>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <omp.h>
#include <random>

namespace dsnake {
namespace {

constexpr double kPi = 3.14159265358979323846;

PointList<2> random_polygon(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PointList<2> q(n);
  for (auto& x : q) x = Point<2>(u(rng), u(rng));
  return q;
}

PointList<2> regular_polygon(int n, double radius, const Point<2>& centre) {
  PointList<2> q(n);
  for (int i = 0; i < n; ++i) {
    const double t = 2 * kPi * i / n;
    q[i] = centre + radius * Point<2>(std::cos(t), std::sin(t));
  }
  return q;
}

Snake<2> polygon_snake(PointList<2> q) {
  const int n = int(q.size());
  std::vector<int> ids(n);
  for (int i = 0; i < n; ++i) ids[i] = i;
  return Snake<2>(std::move(q), Connectivity::polygon(n), ids);
}

// Kass's cyclic pentadiagonal matrix, entry by entry.
Eigen::MatrixXd kass_matrix(int n, double alpha, double beta) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  const double band[5] = {beta, -alpha - 4 * beta, 2 * alpha + 6 * beta, -alpha - 4 * beta, beta};
  for (int i = 0; i < n; ++i)
    for (int k = -2; k <= 2; ++k) a(i, ((i + k) % n + n) % n) += band[k + 2];
  return a;
}

Eigen::MatrixXd as_matrix(const PointList<2>& q) {
  Eigen::MatrixXd m(q.size(), 2);
  for (size_t i = 0; i < q.size(); ++i) m.row(i) = q[i].transpose();
  return m;
}

// Icosahedron with vertices (0, +-1, +-phi) and cyclic permutations; faces are the triples at
// mutual distance 2, oriented outward.
Template<3> icosahedron(const Point<3>& centre, double scale) {
  const double phi = (1 + std::sqrt(5.0)) / 2;
  PointList<3> p;
  for (double s1 : {-1.0, 1.0})
    for (double s2 : {-phi, phi}) {
      p.emplace_back(0, s1, s2);
      p.emplace_back(s1, s2, 0);
      p.emplace_back(s2, 0, s1);
    }
  std::vector<Triangle> tris;
  auto edge = [&](int a, int b) { return std::abs((p[a] - p[b]).norm() - 2.0) < 1e-9; };
  for (int a = 0; a < 12; ++a)
    for (int b = a + 1; b < 12; ++b)
      for (int c = b + 1; c < 12; ++c)
        if (edge(a, b) && edge(b, c) && edge(a, c)) {
          const Point<3> nrm = (p[b] - p[a]).cross(p[c] - p[a]);
          tris.push_back(nrm.dot(p[a]) > 0 ? Triangle{a, b, c} : Triangle{a, c, b});
        }
  Template<3> t;
  for (auto& x : p) t.positions.push_back(centre + scale * x);
  t.connectivity = Connectivity::mesh(12, tris);
  return t;
}

// Splits face 0 with a new vertex at its centroid (pushed outward): valences 3, 5 and 6, so that
// the degree normalisation of the umbrella operator matters.
Template<3> with_split_face(Template<3> t) {
  const Triangle f = t.connectivity.triangles()[0];
  const Point<3> c = (t.positions[f[0]] + t.positions[f[1]] + t.positions[f[2]]) / 3.0;
  t.positions.push_back(1.2 * c);
  std::vector<Triangle> tris(t.connectivity.triangles().begin() + 1, t.connectivity.triangles().end());
  const int v = t.num_vertices() - 1;
  tris.push_back({f[0], f[1], v});
  tris.push_back({f[1], f[2], v});
  tris.push_back({f[2], f[0], v});
  t.connectivity = Connectivity::mesh(v + 1, tris);
  return t;
}

// The per-vertex form with unit parameter steps (Kass's appendix; "discretization": "umbrella"),
// which the hand-built matrices of these tests spell out.
InternalOptions umbrella(double alpha, double beta, double gamma) {
  InternalOptions o{alpha, beta, gamma};
  o.discretization = InternalDiscretization::kUmbrella;
  return o;
}

Eigen::MatrixXd umbrella_matrix(const Connectivity& c) {
  const int n = c.num_vertices();
  Eigen::MatrixXd l = Eigen::MatrixXd::Identity(n, n);
  for (int v = 0; v < n; ++v)
    for (int w : c.neighbors(v)) l(v, w) -= 1.0 / c.neighbors(v).size();
  return l;
}

TEST(InternalEnergy, StepMatchesDenseSolve2d) {
  const InternalOptions o = umbrella(0.7, 0.3, 2.0);
  Snake<2> snake = polygon_snake(random_polygon(7, 1));
  InternalEnergy<2> energy(o);
  energy.bind({}, snake);
  PointList<2> out(7);
  energy.propose(snake, out);
  const Eigen::MatrixXd m = o.gamma * Eigen::MatrixXd::Identity(7, 7) + kass_matrix(7, o.alpha, o.beta);
  const Eigen::MatrixXd expected = m.partialPivLu().solve(o.gamma * as_matrix(snake.positions()));
  for (int i = 0; i < 7; ++i)
    for (int a = 0; a < 2; ++a) EXPECT_NEAR(out[i][a], expected(i, a), 1e-12) << i << "," << a;
}

TEST(InternalEnergy, StepMatchesDenseSolveSmallPolygons2d) {
  // n = 3 and 4: the pentadiagonal band wraps onto itself.
  const InternalOptions o = umbrella(0.4, 0.9, 1.5);
  for (int n : {3, 4, 5}) {
    Snake<2> snake = polygon_snake(random_polygon(n, 10 + n));
    InternalEnergy<2> energy(o);
    energy.bind({}, snake);
    PointList<2> out(n);
    energy.propose(snake, out);
    const Eigen::MatrixXd m = o.gamma * Eigen::MatrixXd::Identity(n, n) + kass_matrix(n, o.alpha, o.beta);
    const Eigen::MatrixXd expected = m.partialPivLu().solve(o.gamma * as_matrix(snake.positions()));
    for (int i = 0; i < n; ++i)
      for (int a = 0; a < 2; ++a) EXPECT_NEAR(out[i][a], expected(i, a), 1e-12) << n;
  }
}

TEST(InternalEnergy, ValueGradientIsKassMatrix2d) {
  const InternalOptions o = umbrella(0.7, 0.3, 2.0);
  Snake<2> snake = polygon_snake(random_polygon(7, 2));
  InternalEnergy<2> energy(o);
  const Eigen::MatrixXd aq = kass_matrix(7, o.alpha, o.beta) * as_matrix(snake.positions());
  const double h = 1e-6;
  for (int i = 0; i < 7; ++i)
    for (int a = 0; a < 2; ++a) {
      const double x0 = snake.positions()[i][a];
      snake.positions()[i][a] = x0 + h;
      const double ep = energy.value(snake);
      snake.positions()[i][a] = x0 - h;
      const double em = energy.value(snake);
      snake.positions()[i][a] = x0;
      const double fd = (ep - em) / (2 * h);
      EXPECT_NEAR(fd, aq(i, a), 1e-6 * std::max(1.0, std::abs(aq(i, a)))) << i << "," << a;
    }
}

// Both discretisations keep a regular polygon regular and about its centroid.
TEST(InternalEnergy, RegularPolygonShrinksAboutCentroid2d) {
  const Point<2> centre(3.0, -2.0);
  const int n = 12;
  Snake<2> snake = polygon_snake(regular_polygon(n, 10.0, centre));
  for (const InternalOptions& o : {umbrella(0.8, 0.0, 1.0), InternalOptions{0.8, 0.0, 1.0}}) {
    SCOPED_TRACE(enum_name(o.discretization));
    InternalEnergy<2> energy(o);
    energy.bind({}, snake);
    PointList<2> out(n);
    energy.propose(snake, out);
    Point<2> centroid = Point<2>::Zero();
    for (const auto& x : out) centroid += x / n;
    EXPECT_NEAR((centroid - centre).norm(), 0.0, 1e-12);
    const double r0 = (out[0] - centre).norm();
    EXPECT_LT(r0, 10.0 - 1e-3);
    for (int i = 0; i < n; ++i) {
      EXPECT_NEAR((out[i] - centre).norm(), r0, 1e-12);
      // Radial shrink: each vertex stays on its own ray (the polygon stays regular).
      const Point<2> expected = centre + (r0 / 10.0) * (snake.positions()[i] - centre);
      EXPECT_NEAR((out[i] - expected).norm(), 0.0, 1e-12);
    }
  }
}

TEST(InternalEnergy, IcosahedronShrinksSymmetrically3d) {
  const Point<3> centre(1.0, 2.0, 3.0);
  const Template<3> ico = icosahedron(centre, 5.0);
  ASSERT_EQ(ico.connectivity.closed_manifold_problem(), "");
  Snake<3> snake = Snake<3>::from_template(ico, ico.positions);
  const double r_before = (snake.positions()[0] - centre).norm();
  for (const InternalOptions& o : {umbrella(0.5, 0.0, 1.0), umbrella(0.5, 0.4, 2.0), InternalOptions{0.5, 0.0, 1.0},
                                   InternalOptions{0.5, 0.4, 2.0}}) {
    SCOPED_TRACE(enum_name(o.discretization));
    InternalEnergy<3> energy(o);
    energy.bind({}, snake);
    PointList<3> out(12);
    energy.propose(snake, out);
    Point<3> centroid = Point<3>::Zero();
    for (const auto& x : out) centroid += x / 12.0;
    EXPECT_NEAR((centroid - centre).norm(), 0.0, 1e-12);
    const double r = (out[0] - centre).norm();
    EXPECT_LT(r, r_before - 1e-3);
    for (const auto& x : out) EXPECT_NEAR((x - centre).norm(), r, 1e-12);
  }
}

TEST(InternalEnergy, StepMatchesDenseSolve3d) {
  for (InternalSolver solver : {InternalSolver::kDirect, InternalSolver::kChebyshev})
  for (bool split : {false, true}) {
    InternalOptions o = umbrella(0.7, 0.3, 2.0);
    o.solver = solver;
    Template<3> mesh = icosahedron(Point<3>::Zero(), 3.0);
    if (split) mesh = with_split_face(mesh);
    ASSERT_EQ(mesh.connectivity.closed_manifold_problem(), "");
    const int n = mesh.num_vertices();
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    for (auto& x : mesh.positions) x += Point<3>(u(rng), u(rng), u(rng));
    Snake<3> snake = Snake<3>::from_template(mesh, mesh.positions);
    InternalEnergy<3> energy(o);
    energy.bind({}, snake);
    PointList<3> out(n);
    energy.propose(snake, out);
    const Eigen::MatrixXd l = umbrella_matrix(snake.connectivity());
    const Eigen::MatrixXd m = o.gamma * Eigen::MatrixXd::Identity(n, n) + o.alpha * l + o.beta * l * l;
    Eigen::MatrixXd q(n, 3);
    for (int i = 0; i < n; ++i) q.row(i) = snake.positions()[i].transpose();
    const Eigen::MatrixXd expected = m.partialPivLu().solve(o.gamma * q);
    for (int i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(out[i][a], expected(i, a), 1e-10) << split << enum_name(solver);
  }
}

// A jittered icosphere with 642 vertices (above the parallel threshold), moved off its rest shape.
Snake<3> jittered_icosphere_snake(unsigned seed, double jitter) {
  Template<3> t = make_icosphere(3);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  for (auto& x : t.positions) x = 10.0 * x + Point<3>(u(rng), u(rng), u(rng));
  return Snake<3>::from_template(t, t.positions);
}

// The Chebyshev step's error bound holds: every vertex within `tolerance` times the step's largest
// displacement of the exact (LDL^T) step, for mild and stiff parameters and a loose and the
// default tolerance; the loose one needs fewer iterations and its error is not below rounding
// (so the bound is exercised, not trivially met).
TEST(InternalEnergy, ChebyshevWithinItsBoundOfTheDirectStep3d) {
  const Snake<3> snake = jittered_icosphere_snake(2, 0.4);
  const int n = snake.num_vertices();
  for (const InternalOptions& base : {umbrella(0.1, 0.0, 1.0), umbrella(0.5, 0.01, 1.0), umbrella(3.0, 1.0, 1.0)}) {
    InternalOptions direct_options = base;
    direct_options.solver = InternalSolver::kDirect;
    InternalEnergy<3> direct(direct_options);
    PointList<3> exact(n);
    direct.bind({}, snake);
    direct.propose(snake, exact);
    EXPECT_EQ(direct.chebyshev_iterations(), 0);
    double max_move = 0;
    for (int v = 0; v < n; ++v) max_move = std::max(max_move, (exact[v] - snake.positions()[v]).norm());
    ASSERT_GT(max_move, 1e-3);
    int loose_iterations = 0;
    for (double tolerance : {1e-4, 1e-10}) {
      InternalOptions o = base;
      o.solver = InternalSolver::kChebyshev;
      o.tolerance = tolerance;
      InternalEnergy<3> cheb(o);
      PointList<3> out(n);
      cheb.bind({}, snake);
      cheb.propose(snake, out);
      double max_error = 0;
      for (int v = 0; v < n; ++v) max_error = std::max(max_error, (out[v] - exact[v]).norm());
      EXPECT_LE(max_error, tolerance * max_move) << base.alpha << " " << tolerance;
      if (tolerance == 1e-4) {
        loose_iterations = cheb.chebyshev_iterations();
        EXPECT_GT(max_error, 1e-13 * max_move) << "the loose solve stops early";
      } else {
        EXPECT_GT(cheb.chebyshev_iterations(), loose_iterations);
      }
    }
  }
}

// The semi-iteration also runs on polygons (Kass's band as a stencil), for n = 3 (the band folds
// onto itself) and larger.
TEST(InternalEnergy, ChebyshevMatchesDenseSolve2d) {
  for (int n : {3, 5, 300}) {
    InternalOptions o = umbrella(0.7, 0.3, 2.0);
    o.solver = InternalSolver::kChebyshev;
    Snake<2> snake = polygon_snake(random_polygon(n, 9));
    InternalEnergy<2> energy(o);
    PointList<2> out(n);
    energy.bind({}, snake);
    energy.propose(snake, out);
    const Eigen::MatrixXd m = o.gamma * Eigen::MatrixXd::Identity(n, n) + kass_matrix(n, o.alpha, o.beta);
    const Eigen::MatrixXd expected = m.partialPivLu().solve(o.gamma * as_matrix(snake.positions()));
    for (int i = 0; i < n; ++i)
      for (int a = 0; a < 2; ++a) EXPECT_NEAR(out[i][a], expected(i, a), 1e-9) << n;
  }
}

// "auto" takes the semi-iteration on well-conditioned meshes only; the Chebyshev step gives the
// same bits on 1 and 2 threads (per-vertex writes, the recurrence replicated per thread).
TEST(InternalEnergy, AutoSolverChoiceAndThreadIndependence) {
  const Snake<3> snake = jittered_icosphere_snake(4, 0.4);
  const int n = snake.num_vertices();
  InternalEnergy<3> mild(umbrella(0.1, 0.01, 1.0));
  PointList<3> a(n), b(n);
  omp_set_num_threads(1);
  mild.bind({}, snake);
  mild.propose(snake, a);
  omp_set_num_threads(2);
  mild.bind({}, snake);
  mild.propose(snake, b);
  EXPECT_GT(mild.chebyshev_iterations(), 0);
  EXPECT_LE(mild.chebyshev_iterations(), 12);
  for (int v = 0; v < n; ++v) EXPECT_EQ(a[v], b[v]);
  InternalEnergy<3> stiff(umbrella(50.0, 0.0, 1.0));
  stiff.bind({}, snake);
  stiff.propose(snake, a);
  EXPECT_EQ(stiff.chebyshev_iterations(), 0);
  InternalEnergy<2> polygon(umbrella(0.1, 0.0, 1.0));
  Snake<2> p = polygon_snake(random_polygon(400, 2));
  PointList<2> out(400);
  polygon.bind({}, p);
  polygon.propose(p, out);
  EXPECT_EQ(polygon.chebyshev_iterations(), 0);
}

TEST(InternalEnergy, ValueGradient3d) {
  // d/dq [sum_edges 1/2 alpha |q_i - q_j|^2 + sum_v 1/2 beta |(Lq)_v|^2] = alpha Lc q + beta L^T L q.
  const InternalOptions o = umbrella(0.7, 0.3, 2.0);
  Template<3> ico = with_split_face(icosahedron(Point<3>::Zero(), 2.0));
  const int n = ico.num_vertices();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (auto& x : ico.positions) x += Point<3>(u(rng), u(rng), u(rng));
  Snake<3> snake = Snake<3>::from_template(ico, ico.positions);
  const Eigen::MatrixXd l = umbrella_matrix(snake.connectivity());
  Eigen::MatrixXd lc = Eigen::MatrixXd::Zero(n, n);
  for (int v = 0; v < n; ++v)
    for (int w : snake.connectivity().neighbors(v)) { lc(v, w) -= 1; lc(v, v) += 1; }
  Eigen::MatrixXd q(n, 3);
  for (int i = 0; i < n; ++i) q.row(i) = snake.positions()[i].transpose();
  const Eigen::MatrixXd grad = o.alpha * lc * q + o.beta * l.transpose() * l * q;
  InternalEnergy<3> energy(o);
  const double h = 1e-6;
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      const double x0 = snake.positions()[i][a];
      snake.positions()[i][a] = x0 + h;
      const double ep = energy.value(snake);
      snake.positions()[i][a] = x0 - h;
      const double em = energy.value(snake);
      snake.positions()[i][a] = x0;
      EXPECT_NEAR((ep - em) / (2 * h), grad(i, a), 1e-6 * std::max(1.0, std::abs(grad(i, a))));
    }
}

TEST(InternalEnergy, RebindsAfterTopologyChange) {
  const InternalOptions o = umbrella(0.6, 0.2, 1.5);
  Snake<2> snake = polygon_snake(random_polygon(7, 5));
  InternalEnergy<2> energy(o);
  energy.bind({}, snake);
  PointList<2> out(7);
  energy.propose(snake, out);

  auto check = [&](const PointList<2>& result) {
    const int n = snake.num_vertices();
    ASSERT_EQ(int(result.size()), n);
    const Eigen::MatrixXd m = o.gamma * Eigen::MatrixXd::Identity(n, n) + kass_matrix(n, o.alpha, o.beta);
    const Eigen::MatrixXd expected = m.partialPivLu().solve(o.gamma * as_matrix(snake.positions()));
    for (int i = 0; i < n; ++i)
      for (int a = 0; a < 2; ++a) EXPECT_NEAR(result[i][a], expected(i, a), 1e-12);
  };

  // As the Evolver does: set_topology, then bind again.
  std::vector<int> ids(10, -1);
  for (int i = 0; i < 7; ++i) ids[i] = i;
  snake.set_topology(random_polygon(10, 6), Connectivity::polygon(10), ids);
  energy.bind({}, snake);
  PointList<2> out10(10);
  energy.propose(snake, out10);
  check(out10);

  // Without the bind, propose refuses the new topology (the phase driver rebinds; an energy does
  // not rebind itself), and works again once bound.
  snake.set_topology(random_polygon(9, 7), Connectivity::polygon(9), std::vector<int>(9, -1));
  PointList<2> out9(9);
  EXPECT_THROW(energy.propose(snake, out9), std::logic_error);
  energy.bind({}, snake);
  energy.propose(snake, out9);
  check(out9);
}

// --- energy registry -------------------------------------------------------------------------

std::unique_ptr<Energy<2>> create_energy(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text);
  JsonReader reader(j, "exp.json", "energies[0]");
  reader.skip("weight");
  return energy_registry<2>().create(reader);
}

std::string error_of(const std::string& text) {
  try {
    create_energy(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(EnergyRegistry, CreatesWithOptions) {
  auto e = create_energy(R"({"type": "internal", "weight": 1, "alpha": 0.7, "beta": 0.2, "gamma": 3})");
  auto* internal = dynamic_cast<InternalEnergy<2>*>(e.get());
  ASSERT_NE(internal, nullptr);
  EXPECT_EQ(internal->options().alpha, 0.7);
  EXPECT_EQ(internal->options().beta, 0.2);
  EXPECT_EQ(internal->options().gamma, 3.0);
  EXPECT_EQ(internal->options().discretization, InternalDiscretization::kPhysical);  // the default
  auto kass = create_energy(R"({"type": "internal", "discretization": "umbrella"})");
  EXPECT_EQ(dynamic_cast<InternalEnergy<2>*>(kass.get())->options().discretization, InternalDiscretization::kUmbrella);
  const nlohmann::json j = nlohmann::json::parse(R"({"type": "external", "tau": 0.5})");
  JsonReader reader(j, "", "energies[1]");
  EXPECT_EQ(energy_registry<3>().create(reader)->type(), "external");
}

TEST(EnergyRegistry, UnknownTypeNamesPathAndKnownTypes) {
  const std::string msg = error_of(R"({"type": "snakeoil", "weight": 1})");
  EXPECT_NE(msg.find("exp.json"), std::string::npos) << msg;
  EXPECT_NE(msg.find("energies[0].type"), std::string::npos) << msg;
  EXPECT_NE(msg.find("snakeoil"), std::string::npos) << msg;
  EXPECT_NE(msg.find("internal"), std::string::npos) << msg;
  EXPECT_NE(msg.find("external"), std::string::npos) << msg;
}

TEST(EnergyRegistry, BadInternalSolverNamesPath) {
  std::string msg = error_of(R"({"type": "internal", "solver": "cg"})");
  EXPECT_NE(msg.find("energies[0].solver"), std::string::npos) << msg;
  msg = error_of(R"({"type": "internal", "solver": "chebyshev", "tolerance": 0})");
  EXPECT_NE(msg.find("energies[0].tolerance"), std::string::npos) << msg;
  // the Chebyshev bound is the umbrella form's: refused with the physical one
  msg = error_of(R"({"type": "internal", "solver": "chebyshev"})");
  EXPECT_NE(msg.find("energies[0].solver"), std::string::npos) << msg;
  EXPECT_NE(msg.find("umbrella"), std::string::npos) << msg;
  EXPECT_EQ(error_of(R"({"type": "internal", "solver": "chebyshev", "discretization": "umbrella"})"), "(no error)");
  msg = error_of(R"({"type": "internal", "discretization": "arc"})");
  EXPECT_NE(msg.find("energies[0].discretization"), std::string::npos) << msg;
}

TEST(EnergyRegistry, UnknownKeyNamesPath) {
  const std::string msg = error_of(R"({"type": "internal", "weight": 1, "foo": 2})");
  EXPECT_NE(msg.find("energies[0].foo"), std::string::npos) << msg;
}

TEST(EnergyRegistry, WrongTypeNamesPath) {
  const std::string msg = error_of(R"({"type": "internal", "alpha": "x"})");
  EXPECT_NE(msg.find("energies[0].alpha"), std::string::npos) << msg;
}

TEST(EnergyRegistry, OutOfRangeNamesPath) {
  EXPECT_NE(error_of(R"({"type": "internal", "alpha": -1})").find("energies[0].alpha"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "internal", "beta": -0.1})").find("energies[0].beta"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "internal", "gamma": 0})").find("energies[0].gamma"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "external", "tau": 0})").find("energies[0].tau"), std::string::npos);
}

}  // namespace
}  // namespace dsnake
