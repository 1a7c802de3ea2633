// ExternalEnergy with stub fields: the step q + tau F, the normals it passes to the field (both
// orientations of a contour, a closed mesh), its value, and its binding contract.
#include "energies/external.h"

#include "framework/core/external_field.h"

#include <Eigen/Geometry>
#include <cmath>
#include <gtest/gtest.h>
#include <stdexcept>

namespace dsnake {
namespace {

constexpr double kPi = 3.14159265358979323846;

// F = c everywhere, potential P(x) = |x|^2.
template <int D>
class ConstantField final : public ExternalField<D> {
 public:
  explicit ConstantField(const Point<D>& c) : c_(c) {}
  std::string type() const override { return "constant"; }
  void compute(const Image<D>&) override {}
  Point<D> force(const Point<D>&, const Point<D>&) const override { return c_; }
  bool has_potential() const override { return true; }
  double potential(const Point<D>& x) const override { return x.squaredNorm(); }
  const VectorField<D>& vectors() const override { return vectors_; }

 private:
  Point<D> c_;
  VectorField<D> vectors_;
};

// F = the normal it is given, so that propose() reveals the normals (no potential).
template <int D>
class NormalField final : public ExternalField<D> {
 public:
  std::string type() const override { return "normal"; }
  void compute(const Image<D>&) override {}
  Point<D> force(const Point<D>&, const Point<D>& n) const override { return n; }
  bool uses_normal() const override { return true; }
  const VectorField<D>& vectors() const override { return vectors_; }

 private:
  VectorField<D> vectors_;
};

Snake<2> circle(int n, double radius, const Point<2>& centre, bool counter_clockwise) {
  PointList<2> q(n);
  for (int i = 0; i < n; ++i) {
    const double t = (counter_clockwise ? 1 : -1) * 2 * kPi * i / n;
    q[i] = centre + radius * Point<2>(std::cos(t), std::sin(t));
  }
  std::vector<int> ids(n);
  for (int i = 0; i < n; ++i) ids[i] = i;
  return Snake<2>(std::move(q), Connectivity::polygon(n), ids);
}

TEST(ExternalEnergy, StepIsPositionPlusTauForce) {
  const Point<2> c(0.25, -1.5);
  ConstantField<2> field(c);
  Snake<2> snake = circle(9, 4.0, Point<2>(1, 2), true);
  ExternalEnergy<2> energy({0.3});
  EnergyContext<2> context;
  context.field = &field;
  energy.bind(context, snake);
  PointList<2> out(9);
  energy.propose(snake, out);
  for (int v = 0; v < 9; ++v) EXPECT_EQ(out[v], Point<2>(snake.positions()[v] + 0.3 * c));
}

// F sampled from a 4 x 3 grid of vectors (linear interpolation), all (1, 0) but one of (3, -4).
class GridField final : public ExternalField<2> {
 public:
  GridField() : vectors_(Grid<2>{GridIndex<2>(4, 3), Point<2>(0.5, 2.0), Point<2>(-1, 1)}) {
    for (int64_t l = 0; l < vectors_.num_voxels(); ++l) vectors_[l] = Point<2>(1, 0);
    vectors_[5] = Point<2>(3, -4);
  }
  std::string type() const override { return "grid"; }
  void compute(const Image<2>&) override {}
  Point<2> force(const Point<2>& x, const Point<2>&) const override { return vectors_.sample(x); }
  const VectorField<2>& vectors() const override { return vectors_; }

 private:
  VectorField<2> vectors_;
};

// normalize "max": tau is the step in mm where the force is strongest (|F|_max = 5 here), so the
// same tau moves a vertex as far whatever the field's scale; "none" keeps tau * F.
TEST(ExternalEnergy, NormalizeMaxMakesTauTheStepAtTheStrongestForce) {
  GridField field;
  Snake<2> snake = circle(5, 0.4, Point<2>(0.0, 3.0), true);  // inside the grid
  EnergyContext<2> context;
  context.field = &field;
  ExternalOptions o;
  o.tau = 0.3;
  o.normalize = ForceNormalization::kMax;
  ExternalEnergy<2> normalized(o), raw({0.3});
  normalized.bind(context, snake);
  raw.bind(context, snake);
  EXPECT_DOUBLE_EQ(normalized.force_scale(), 0.2);
  EXPECT_DOUBLE_EQ(raw.force_scale(), 1.0);
  PointList<2> a(5), b(5);
  normalized.propose(snake, a);
  raw.propose(snake, b);
  for (int v = 0; v < 5; ++v) {
    const Point<2> q = snake.positions()[v], f = field.force(q, Point<2>::Zero());
    EXPECT_NEAR((a[v] - (q + 0.3 * f / 5.0)).norm(), 0.0, 1e-15);
    EXPECT_NEAR((b[v] - (q + 0.3 * f)).norm(), 0.0, 1e-15);
  }
  // At the strongest voxel's centre the normalized step is exactly tau.
  Snake<2> at_max(PointList<2>{field.vectors().grid().to_physical(GridIndex<2>(1, 1)), Point<2>(0, 2), Point<2>(0.2, 3)},
                  Connectivity::polygon(3), std::vector<int>{0, 1, 2});
  PointList<2> c(3);
  normalized.bind(context, at_max);
  normalized.propose(at_max, c);
  EXPECT_NEAR((c[0] - at_max.positions()[0]).norm(), 0.3, 1e-12);
}

// normalize "unit" (Xu & Prince's GVF snake): every vertex steps exactly tau along the field's
// direction, however weak or strong the force there; a zero force gives no step.
TEST(ExternalEnergy, NormalizeUnitStepsEveryVertexByTau) {
  GridField field;
  Snake<2> snake = circle(7, 0.6, Point<2>(0.0, 3.0), true);
  EnergyContext<2> context;
  context.field = &field;
  ExternalOptions o;
  o.tau = 0.3;
  o.normalize = ForceNormalization::kUnit;
  ExternalEnergy<2> unit(o);
  unit.bind(context, snake);
  EXPECT_DOUBLE_EQ(unit.force_scale(), 1.0);
  PointList<2> out(7);
  unit.propose(snake, out);
  for (int v = 0; v < 7; ++v) {
    const Point<2> q = snake.positions()[v], f = field.force(q, Point<2>::Zero());
    EXPECT_NEAR((out[v] - q).norm(), 0.3, 1e-12) << v;
    EXPECT_NEAR((out[v] - q).normalized().dot(f.normalized()), 1.0, 1e-12) << v;
  }
  ConstantField<2> zero(Point<2>::Zero());
  context.field = &zero;
  unit.bind(context, snake);
  unit.propose(snake, out);
  for (int v = 0; v < 7; ++v) EXPECT_EQ(out[v], snake.positions()[v]);
}

TEST(ExternalEnergy, ValueIsSumOfPotential) {
  ConstantField<2> with_potential(Point<2>(1, 0));
  NormalField<2> without_potential;
  Snake<2> snake = circle(6, 2.0, Point<2>(1, 0), true);
  double expected = 0;
  for (const auto& x : snake.positions()) expected += x.squaredNorm();
  ExternalEnergy<2> energy;
  EnergyContext<2> context;
  context.field = &with_potential;
  energy.bind(context, snake);
  EXPECT_NEAR(energy.value(snake), expected, 1e-12);
  context.field = &without_potential;
  energy.bind(context, snake);
  EXPECT_TRUE(std::isnan(energy.value(snake)));
}

TEST(ExternalEnergy, PassesOutwardNormalsInBothOrientations2d) {
  NormalField<2> field;
  const Point<2> centre(-3, 5);
  for (bool ccw : {true, false}) {
    Snake<2> snake = circle(16, 7.0, centre, ccw);
    ASSERT_EQ(snake.signed_measure() > 0, ccw);
    ExternalEnergy<2> energy({2.0});
    EnergyContext<2> context;
    context.field = &field;
    energy.bind(context, snake);
    PointList<2> out(16);
    energy.propose(snake, out);
    for (int v = 0; v < 16; ++v) {
      const Point<2> radial = (snake.positions()[v] - centre).normalized();
      const Point<2> normal = (out[v] - snake.positions()[v]) / 2.0;
      EXPECT_NEAR((normal - radial).norm(), 0.0, 1e-12) << (ccw ? "ccw " : "cw ") << v;
    }
  }
}

TEST(ExternalEnergy, PassesOutwardNormals3d) {
  // Octahedron: vertices +-e_a, one outward-oriented face per octant.
  PointList<3> p;
  for (int a = 0; a < 3; ++a)
    for (double s : {1.0, -1.0}) p.push_back(s * Point<3>::Unit(a));
  std::vector<Triangle> tris;
  for (int sx = 0; sx < 2; ++sx)
    for (int sy = 0; sy < 2; ++sy)
      for (int sz = 0; sz < 2; ++sz) {
        const int a = sx, b = 2 + sy, c = 4 + sz;
        const Point<3> nrm = (p[b] - p[a]).cross(p[c] - p[a]);
        tris.push_back(nrm.dot(p[a] + p[b] + p[c]) > 0 ? Triangle{a, b, c} : Triangle{a, c, b});
      }
  const Point<3> centre(1, 2, 3);
  for (auto& x : p) x = centre + 2.0 * x;
  Snake<3> snake(p, Connectivity::mesh(6, tris), {0, 1, 2, 3, 4, 5});
  ASSERT_EQ(snake.connectivity().closed_manifold_problem(), "");
  NormalField<3> field;
  ExternalEnergy<3> energy;
  EnergyContext<3> context;
  context.field = &field;
  energy.bind(context, snake);
  PointList<3> out(6);
  energy.propose(snake, out);
  for (int v = 0; v < 6; ++v) {
    const Point<3> radial = (p[v] - centre).normalized();
    EXPECT_NEAR((out[v] - p[v] - radial).norm(), 0.0, 1e-12) << v;
  }
}

TEST(ExternalEnergy, BindWithoutFieldIsAProgrammerError) {
  Snake<2> snake = circle(5, 1.0, Point<2>::Zero(), true);
  ExternalEnergy<2> energy;
  EXPECT_THROW(energy.bind(EnergyContext<2>{}, snake), std::logic_error);
}

}  // namespace
}  // namespace dsnake
