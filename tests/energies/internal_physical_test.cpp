// InternalEnergy, "discretization": "physical" (energies/internal.h): the step against a dense
// solve built from the textbook formulas (edge weights 1 / l, cotangents from the angles, mixed
// Voronoi areas), the continuous flow on circles and spheres at every resolution (the same alpha),
// the scaling law, the value against hand-computed numbers and its residuals, degenerate elements
// and thread independence; the umbrella form's resolution dependence for contrast.
#include "energies/internal.h"
#include "experiments/phantoms/phantoms.h"
#include "framework/global/global_problem.h"
#include "tests/energy_fixtures.h"

#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <cmath>
#include <gtest/gtest.h>
#include <omp.h>
#include <type_traits>

namespace dsnake {
namespace {

using test_support::perturbed;
using test_support::wobbly_polygon;
using test_support::wobbly_sphere;

constexpr double kPi = 3.14159265358979323846;

InternalOptions physical(double alpha, double beta, double gamma) { return InternalOptions{alpha, beta, gamma}; }

Template<2> regular_polygon(int n, double radius, const Point<2>& centre) {
  Template<2> t;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * kPi * i / n;
    t.positions.push_back(centre + radius * Point<2>(std::cos(a), std::sin(a)));
  }
  t.connectivity = Connectivity::polygon(n);
  return t;
}

Template<3> sphere(int subdivisions, double radius, const Point<3>& centre) {
  Template<3> t = make_icosphere(subdivisions);
  for (auto& p : t.positions) p = centre + radius * p;
  return t;
}

template <int D>
PointList<D> step(const InternalOptions& o, const Snake<D>& snake) {
  InternalEnergy<D> energy(o);
  energy.bind({}, snake);
  PointList<D> out(snake.num_vertices());
  energy.propose(snake, out);
  return out;
}

template <int D>
Eigen::MatrixXd as_matrix(const PointList<D>& q) {
  Eigen::MatrixXd m(q.size(), D);
  for (size_t i = 0; i < q.size(); ++i) m.row(i) = q[i].transpose();
  return m;
}

// K and M from the textbook formulas, densely: 2D K = sum_edges (1 / l)(e_i - e_j)(e_i - e_j)^T,
// M_i = (l_{i-1,i} + l_{i,i+1}) / 2; 3D K_ij = -1/2 (cot a + cot b) with the angles from atan2,
// M_i the mixed Voronoi area (Meyer et al. 2003).
struct Dense {
  Eigen::MatrixXd k;
  Eigen::VectorXd m;
};

Dense dense_operators(const Snake<2>& snake) {
  const int n = snake.num_vertices();
  Dense d{Eigen::MatrixXd::Zero(n, n), Eigen::VectorXd::Zero(n)};
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    const double l = (snake.positions()[j] - snake.positions()[i]).norm();
    d.k(i, i) += 1 / l, d.k(j, j) += 1 / l, d.k(i, j) -= 1 / l, d.k(j, i) -= 1 / l;
    d.m[i] += l / 2, d.m[j] += l / 2;
  }
  return d;
}

Dense dense_operators(const Snake<3>& snake) {
  const int n = snake.num_vertices();
  const PointList<3>& q = snake.positions();
  Dense d{Eigen::MatrixXd::Zero(n, n), Eigen::VectorXd::Zero(n)};
  for (const Triangle& t : snake.connectivity().triangles()) {
    double angle[3], cot[3];
    for (int c = 0; c < 3; ++c) {
      const Point<3> u = q[t[(c + 1) % 3]] - q[t[c]], v = q[t[(c + 2) % 3]] - q[t[c]];
      angle[c] = std::atan2(u.cross(v).norm(), u.dot(v));
      cot[c] = 1 / std::tan(angle[c]);
    }
    const double area = 0.5 * (q[t[1]] - q[t[0]]).cross(q[t[2]] - q[t[0]]).norm();
    for (int c = 0; c < 3; ++c) {
      const int i = t[(c + 1) % 3], j = t[(c + 2) % 3];
      d.k(i, j) -= cot[c] / 2, d.k(j, i) -= cot[c] / 2, d.k(i, i) += cot[c] / 2, d.k(j, j) += cot[c] / 2;
      const bool obtuse = angle[0] > kPi / 2 || angle[1] > kPi / 2 || angle[2] > kPi / 2;
      // Voronoi part at t[c]: 1/8 (|t[c] t[c+1]|^2 cot(c+2) + |t[c] t[c+2]|^2 cot(c+1))
      d.m[t[c]] += obtuse ? (angle[c] > kPi / 2 ? area / 2 : area / 4)
                          : ((q[i] - q[t[c]]).squaredNorm() * cot[(c + 2) % 3] + (q[j] - q[t[c]]).squaredNorm() * cot[(c + 1) % 3]) / 8;
    }
  }
  return d;
}

// (gamma M + alpha K + beta K M^-1 K)^-1 gamma M q, densely.
template <int D>
Eigen::MatrixXd dense_step(const InternalOptions& o, const Snake<D>& snake) {
  const Dense d = dense_operators(snake);
  const Eigen::MatrixXd system = o.gamma * Eigen::MatrixXd(d.m.asDiagonal()) + o.alpha * d.k +
                                 o.beta * d.k * d.m.cwiseInverse().asDiagonal() * d.k;
  return system.partialPivLu().solve(o.gamma * d.m.asDiagonal() * as_matrix<D>(snake.positions()));
}

template <int D>
void expect_step_matches_dense(const InternalOptions& o, const Snake<D>& snake, const std::string& label) {
  SCOPED_TRACE(label);
  const PointList<D> out = step<D>(o, snake);
  const Eigen::MatrixXd expected = dense_step<D>(o, snake);
  for (int i = 0; i < snake.num_vertices(); ++i)
    for (int a = 0; a < D; ++a) ASSERT_NEAR(out[i][a], expected(i, a), 1e-10) << i << "," << a;
}

// The assembled, permuted and refactorised system against the dense solve, with and without
// rigidity (the two-ring pattern), on irregular shapes; after a move (operators refreshed from
// the new positions without a rebind) and after a topology change (rebind).
TEST(InternalPhysical, StepMatchesDenseSolve) {
  for (const InternalOptions& o : {physical(0.7, 0.0, 2.0), physical(0.7, 3.0, 2.0), physical(40.0, 200.0, 1.0)}) {
    const std::string label = std::to_string(o.alpha) + " " + std::to_string(o.beta);
    const Template<2> polygon = wobbly_polygon(23, 10.0);
    expect_step_matches_dense<2>(o, Snake<2>::from_template(polygon, perturbed<2>(polygon.positions, 0.5, 1)), "2D " + label);
    const Template<3> mesh = wobbly_sphere(2, 10.0);
    expect_step_matches_dense<3>(o, Snake<3>::from_template(mesh, perturbed<3>(mesh.positions, 0.3, 2)), "3D " + label);
  }
  const InternalOptions o = physical(0.6, 1.0, 1.5);
  const Template<3> mesh = wobbly_sphere(1, 8.0);
  Snake<3> snake = Snake<3>::from_template(mesh, mesh.positions);
  InternalEnergy<3> energy(o);
  energy.bind({}, snake);
  PointList<3> out(snake.num_vertices());
  energy.propose(snake, out);
  snake.positions() = perturbed<3>(snake.positions(), 0.8, 3);  // moved: the next step sees the new M, K
  energy.propose(snake, out);
  const Eigen::MatrixXd expected = dense_step<3>(o, snake);
  for (int i = 0; i < snake.num_vertices(); ++i) EXPECT_NEAR((out[i] - Point<3>(expected.row(i).transpose())).norm(), 0, 1e-10);
  const Template<3> finer = wobbly_sphere(2, 8.0);
  snake.set_topology(finer.positions, finer.connectivity, std::vector<int>(finer.num_vertices(), -1));
  energy.bind({}, snake);
  PointList<3> finer_out(snake.num_vertices());
  energy.propose(snake, finer_out);
  const Eigen::MatrixXd finer_expected = dense_step<3>(o, snake);
  for (int i = 0; i < snake.num_vertices(); ++i)
    EXPECT_NEAR((finer_out[i] - Point<3>(finer_expected.row(i).transpose())).norm(), 0, 1e-10);
}

// A regular n-gon of radius R is an eigenvector of the discretisation: K q = M q / R^2 about the
// centre (edge l = 2 R sin(pi / n), (K q)_i = 4 sin^2(pi / n) / l q_i = l / R^2 q_i, M_i = l), so
// one step scales it by gamma / (gamma + a), a = alpha / R^2 + beta / R^4: every vertex moves
// inward by R a / (gamma + a) for every n (~ alpha / (gamma R): the curve-shortening flow
// gamma X_t = alpha X_ss, |X_ss| = 1 / R). The umbrella form's move falls with n^2.
TEST(InternalPhysical, CircleMovesByTheContinuousFlowAtEveryResolution2d) {
  const Point<2> centre(3.0, -2.0);
  const double radius = 10.0;
  for (const InternalOptions& o : {physical(0.5, 0.0, 1.0), physical(0.5, 20.0, 1.0), physical(3.0, 0.0, 2.0)}) {
    const double a = o.alpha / (radius * radius) + o.beta / std::pow(radius, 4);
    const double expected = radius * a / (o.gamma + a);
    for (int n : {32, 64, 256}) {
      const Template<2> t = regular_polygon(n, radius, centre);
      const PointList<2> out = step<2>(o, Snake<2>::from_template(t, t.positions));
      for (int i = 0; i < n; ++i) {
        const Point<2> inward = (centre - t.positions[i]) / radius;
        // to rounding (the rigid n = 256 step's system has condition ~1e4)
        EXPECT_NEAR((out[i] - t.positions[i]).dot(inward), expected, 1e-9) << n << " " << o.alpha << " " << o.beta;
        EXPECT_NEAR((out[i] - t.positions[i] - expected * inward).norm(), 0, 1e-9);
      }
    }
  }
  // alpha 0.5 mm^2, R 10 mm: ~ alpha / (gamma R) = 0.05 mm (the implicit step: 0.05 / 1.005)
  EXPECT_NEAR(radius * 0.005 / 1.005, 0.05, 0.0003);
  InternalOptions kass{0.5, 0.0, 1.0};
  kass.discretization = InternalDiscretization::kUmbrella;
  const Template<2> coarse = regular_polygon(32, radius, centre), fine = regular_polygon(256, radius, centre);
  const double coarse_move = (step<2>(kass, Snake<2>::from_template(coarse, coarse.positions))[0] - coarse.positions[0]).norm();
  const double fine_move = (step<2>(kass, Snake<2>::from_template(fine, fine.positions))[0] - fine.positions[0]).norm();
  EXPECT_GT(coarse_move / fine_move, 50.0);  // 4 alpha sin^2(pi / n) R / (1 + ...): ~63x
}

// Icospheres of 162, 642 and 2562 vertices, radius 10 mm: every vertex moves inward by the
// sphere's flow R a / (gamma + a), a = 2 alpha / R^2 + 4 beta / R^4 (mean curvature flow, H = 1 / R,
// Delta X = -2 X / R^2), the same alpha at every resolution: the radial part within 0.5%
// (measured: <= 0.03% with beta 0, 0.18% with beta), the cotangent Laplacian's tangential drift
// within 4% of the move (measured 1.3% / 3.5% at 162 vertices), falling with refinement.
TEST(InternalPhysical, IcosphereMovesByMeanCurvatureFlowAtEveryResolution3d) {
  const Point<3> centre(1.0, 2.0, 3.0);
  const double radius = 10.0;
  for (const InternalOptions& o : {physical(0.5, 0.0, 1.0), physical(0.5, 10.0, 1.0), physical(5.0, 0.0, 2.0)}) {
    const double a = 2 * o.alpha / (radius * radius) + 4 * o.beta / std::pow(radius, 4);
    const double expected = radius * a / (o.gamma + a);
    double last_tangential = 1;
    for (int subdivisions : {2, 3, 4}) {
      const Template<3> t = sphere(subdivisions, radius, centre);
      SCOPED_TRACE(std::to_string(t.num_vertices()) + " vertices, alpha " + std::to_string(o.alpha));
      const PointList<3> out = step<3>(o, Snake<3>::from_template(t, t.positions));
      double worst = 0, tangential = 0;
      for (int i = 0; i < t.num_vertices(); ++i) {
        const Point<3> inward = (centre - t.positions[i]) / radius, move = out[i] - t.positions[i];
        worst = std::max(worst, std::abs(move.dot(inward) / expected - 1));
        tangential = std::max(tangential, (move - move.dot(inward) * inward).norm() / expected);
      }
      EXPECT_LE(worst, 5e-3);
      EXPECT_LE(tangential, 0.04);
      EXPECT_LT(tangential, last_tangential);  // the discretisation's drift falls with refinement
      last_tangential = tangential;
    }
  }
}

// Scaling a shape by s scales its step by s as the step with alpha / s^2, beta / s^4 does (M ~ s^(D-1),
// K ~ s^(D-3)); on a sphere the move is then ~ 1/R: doubling R halves it, up to the implicit
// factor (gamma + 2 alpha / R^2) / (gamma + alpha / (2 R^2)).
TEST(InternalPhysical, ScaledShapeMovesAsTheContinuousFlowPredicts) {
  const double s = 2.0;
  const InternalOptions o = physical(0.8, 3.0, 1.0), shrunk = physical(0.8 / (s * s), 3.0 / std::pow(s, 4), 1.0);
  const Template<2> polygon = wobbly_polygon(40, 10.0);
  PointList<2> big2 = polygon.positions;
  for (auto& p : big2) p *= s;
  const PointList<2> out2 = step<2>(o, Snake<2>::from_template(polygon, big2));
  const PointList<2> ref2 = step<2>(shrunk, Snake<2>::from_template(polygon, polygon.positions));
  for (int i = 0; i < polygon.num_vertices(); ++i) EXPECT_NEAR((out2[i] - s * ref2[i]).norm(), 0, 1e-11);
  const Template<3> mesh = wobbly_sphere(2, 10.0);
  PointList<3> big3 = mesh.positions;
  for (auto& p : big3) p *= s;
  const PointList<3> out3 = step<3>(o, Snake<3>::from_template(mesh, big3));
  const PointList<3> ref3 = step<3>(shrunk, Snake<3>::from_template(mesh, mesh.positions));
  for (int i = 0; i < mesh.num_vertices(); ++i) EXPECT_NEAR((out3[i] - s * ref3[i]).norm(), 0, 1e-11);

  const InternalOptions mild = physical(0.5, 0.0, 1.0);
  const double r = 10.0;
  const Template<3> small = sphere(3, r, Point<3>::Zero()), large = sphere(3, s * r, Point<3>::Zero());
  const double small_move = r - step<3>(mild, Snake<3>::from_template(small, small.positions))[0].norm();
  const double large_move = s * r - step<3>(mild, Snake<3>::from_template(large, large.positions))[0].norm();
  const double predicted = (1 + 2 * 0.5 / (r * r)) / (1 + 2 * 0.5 / (s * s * r * r)) / s;
  EXPECT_NEAR(large_move / small_move, predicted, 1e-3 * predicted);
  EXPECT_NEAR(large_move / small_move, 0.5, 0.01);
}

// Hand-computed: the square of side 2 about the origin: l = 2, M_i = 2, (K q)_i = (2 q_i - q_prev
// - q_next) / 2 = q_i, so E = 1/2 alpha 4 (4 / 2) + 1/2 beta 4 |q_i|^2 / 2 = 4 alpha + 2 beta; the
// regular tetrahedron with edge 2 (area sqrt(3) per face): the tension term alone is alpha times
// the area, 4 sqrt(3) alpha.
TEST(InternalPhysical, ValueIsTheContinuousEnergy) {
  Template<2> square{{{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}, Connectivity::polygon(4), {}};
  EXPECT_NEAR(InternalEnergy<2>(physical(0.7, 0.0, 1.0)).value(Snake<2>::from_template(square, square.positions)), 2.8, 1e-14);
  EXPECT_NEAR(InternalEnergy<2>(physical(0.7, 0.3, 1.0)).value(Snake<2>::from_template(square, square.positions)), 3.4, 1e-14);
  Template<3> tetra;
  tetra.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  for (auto& p : tetra.positions) p /= std::sqrt(2.0);  // edge 2
  std::vector<Triangle> faces;
  for (Triangle f : {Triangle{0, 1, 2}, Triangle{0, 1, 3}, Triangle{0, 2, 3}, Triangle{1, 2, 3}}) {
    const PointList<3>& p = tetra.positions;
    if ((p[f[1]] - p[f[0]]).cross(p[f[2]] - p[f[0]]).dot(p[f[0]] + p[f[1]] + p[f[2]]) < 0) std::swap(f[1], f[2]);
    faces.push_back(f);
  }
  tetra.connectivity = Connectivity::mesh(4, faces);
  ASSERT_EQ(tetra.connectivity.closed_manifold_problem(), "");
  EXPECT_NEAR(InternalEnergy<3>(physical(0.7, 0.0, 1.0)).value(Snake<3>::from_template(tetra, tetra.positions)),
              0.7 * 4 * std::sqrt(3.0), 1e-13);
}

// value() = 1/2 alpha q^T K q + 1/2 beta q^T K M^-1 K q with the dense K, M; the residuals' squares
// sum to weight times it; and Ceres' gradient of 1/2 sum r^2 (coefficients frozen) is
// weight / 2 (alpha K + beta K M^-1 K) q, the step's operator.
template <int D>
void expect_residuals_match(const Snake<D>& snake, const InternalOptions& o, double weight) {
  const Dense d = dense_operators(snake);
  const Eigen::MatrixXd q = as_matrix<D>(snake.positions());
  const Eigen::MatrixXd kq = d.k * q;
  const double expected = 0.5 * o.alpha * (q.array() * kq.array()).sum() +
                          0.5 * o.beta * (kq.transpose() * d.m.cwiseInverse().asDiagonal() * kq).trace();
  InternalEnergy<D> energy(o);
  EXPECT_NEAR(energy.value(snake), expected, 1e-10 * expected);
  GlobalProblem<D> problem(snake);
  ASSERT_TRUE(energy.add_residuals(snake, weight, problem));
  EXPECT_NEAR(problem.sum_of_squares(), weight * energy.value(snake), 1e-10 * weight * expected);
  double cost = 0;
  std::vector<double> gradient;
  problem.problem().Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, &gradient, nullptr);
  const Eigen::MatrixXd g = 0.5 * weight * (o.alpha * kq + o.beta * d.k * d.m.cwiseInverse().asDiagonal() * kq);
  ASSERT_EQ(gradient.size(), size_t(snake.num_vertices()) * D);
  for (int v = 0; v < snake.num_vertices(); ++v)
    for (int a = 0; a < D; ++a) EXPECT_NEAR(gradient[size_t(v) * D + a], g(v, a), 1e-9 * (1 + g.cwiseAbs().maxCoeff()));
}

TEST(InternalPhysical, ResidualsSumToTheValueWithTheStepsGradient) {
  const Template<2> polygon = wobbly_polygon(20, 10.0);
  const Template<3> mesh = wobbly_sphere(1, 10.0);
  for (const InternalOptions& o : {physical(0.6, 0.0, 1.0), physical(0.6, 2.0, 1.0), physical(0.0, 2.0, 1.0)}) {
    expect_residuals_match<2>(Snake<2>::from_template(polygon, perturbed<2>(polygon.positions, 1.0, 4)), o, 0.7);
    expect_residuals_match<3>(Snake<3>::from_template(mesh, perturbed<3>(mesh.positions, 1.0, 5)), o, 0.7);
  }
}

// Degenerate elements: a zero-area triangle (a vertex on its opposite edge's midpoint), a
// zero-length edge (a vertex on its neighbour), every vertex at one point; 2D two coincident
// vertices and a collapsed polygon. Step, value and residuals stay finite (the floors of
// internal.h), and the residuals still sum to the value.
template <int D>
void expect_finite(const Template<D>& t, const PointList<D>& q, const std::string& label) {
  SCOPED_TRACE(label);
  const Snake<D> snake = Snake<D>::from_template(t, q);
  const InternalOptions o = physical(0.5, 2.0, 1.0);
  for (const auto& x : step<D>(o, snake)) EXPECT_TRUE(x.allFinite());
  InternalEnergy<D> energy(o);
  EXPECT_TRUE(std::isfinite(energy.value(snake)));
  GlobalProblem<D> problem(snake);
  energy.add_residuals(snake, 1.0, problem);
  EXPECT_TRUE(std::isfinite(problem.sum_of_squares()));
  EXPECT_NEAR(problem.sum_of_squares(), energy.value(snake), 1e-9 * (1 + energy.value(snake)));
}

TEST(InternalPhysical, FiniteOnDegenerateElements) {
  const Template<3> mesh = sphere(1, 10.0, Point<3>::Zero());
  const Triangle f = mesh.connectivity.triangles()[0];
  PointList<3> flat = mesh.positions;
  flat[f[0]] = 0.5 * (flat[f[1]] + flat[f[2]]);
  expect_finite<3>(mesh, flat, "zero-area triangle");
  PointList<3> merged = mesh.positions;
  merged[f[0]] = merged[f[1]];
  expect_finite<3>(mesh, merged, "zero-length edge");
  expect_finite<3>(mesh, PointList<3>(mesh.num_vertices(), Point<3>(1, 2, 3)), "one point");
  const Template<2> polygon = regular_polygon(12, 10.0, Point<2>::Zero());
  PointList<2> doubled = polygon.positions;
  doubled[3] = doubled[4];
  expect_finite<2>(polygon, doubled, "coincident vertices");
  expect_finite<2>(polygon, PointList<2>(12, Point<2>(1, 2)), "one point");
}

// The physical step is assembled and solved serially: the same bits on 1 and 2 threads; "auto"
// takes the direct solve (no Chebyshev iterations).
TEST(InternalPhysical, SameBitsOnOneAndTwoThreadsAndAutoSolvesDirectly) {
  const Template<3> mesh = wobbly_sphere(3, 10.0);
  const Snake<3> snake = Snake<3>::from_template(mesh, perturbed<3>(mesh.positions, 0.4, 6));
  const Template<2> polygon = wobbly_polygon(400, 100.0);
  const Snake<2> contour = Snake<2>::from_template(polygon, perturbed<2>(polygon.positions, 0.4, 7));
  const InternalOptions o = physical(0.5, 1.0, 1.0);
  omp_set_num_threads(1);
  const PointList<3> one = step<3>(o, snake);
  const PointList<2> one2 = step<2>(o, contour);
  omp_set_num_threads(2);
  const PointList<3> two = step<3>(o, snake);
  const PointList<2> two2 = step<2>(o, contour);
  for (int v = 0; v < snake.num_vertices(); ++v) EXPECT_EQ(one[v], two[v]);
  for (int v = 0; v < contour.num_vertices(); ++v) EXPECT_EQ(one2[v], two2[v]);
  InternalEnergy<3> mild(physical(0.1, 0.01, 1.0));
  mild.bind({}, snake);
  EXPECT_EQ(mild.chebyshev_iterations(), 0);
}

}  // namespace
}  // namespace dsnake

namespace dsnake {
namespace {

// With beta = 0, "auto" solves the physical step by conjugate gradients: within 1e-9 of the
// step's largest move of the refactorised direct solve, in tens of iterations, on a 642-vertex
// wobbly sphere and a 400-vertex contour; alpha = beta = 0 is the identity, exactly.
TEST(InternalPhysical, ConjugateGradientsAgreeWithTheDirectSolve) {
  const Template<3> mesh = wobbly_sphere(3, 10.0);
  const Snake<3> snake = Snake<3>::from_template(mesh, perturbed<3>(mesh.positions, 0.4, 6));
  const Template<2> polygon = wobbly_polygon(400, 100.0);
  const Snake<2> contour = Snake<2>::from_template(polygon, perturbed<2>(polygon.positions, 0.4, 7));
  InternalOptions cg = physical(0.5, 0.0, 1.0), direct = cg;
  direct.solver = InternalSolver::kDirect;
  auto expect_agree = [&](const auto& s, auto tag) {
    constexpr int D = decltype(tag)::value;
    InternalEnergy<D> a(cg), b(direct);
    a.bind({}, s);
    b.bind({}, s);
    PointList<D> x(s.num_vertices()), y(s.num_vertices());
    a.propose(s, x);
    b.propose(s, y);
    EXPECT_GT(a.conjugate_gradient_iterations(), 0);
    EXPECT_LT(a.conjugate_gradient_iterations(), 100);
    EXPECT_EQ(b.conjugate_gradient_iterations(), 0);
    double move = 0, diff = 0;
    for (int v = 0; v < s.num_vertices(); ++v) {
      move = std::max(move, (y[v] - s.positions()[v]).norm());
      diff = std::max(diff, (x[v] - y[v]).norm());
    }
    EXPECT_GT(move, 1e-3);
    EXPECT_LE(diff, 1e-9 * move);
  };
  expect_agree(snake, std::integral_constant<int, 3>());
  expect_agree(contour, std::integral_constant<int, 2>());
  InternalEnergy<3> identity(physical(0.0, 0.0, 1.0));
  identity.bind({}, snake);
  PointList<3> out(snake.num_vertices());
  identity.propose(snake, out);
  for (int v = 0; v < snake.num_vertices(); ++v) EXPECT_EQ(out[v], snake.positions()[v]);
}

}  // namespace
}  // namespace dsnake
