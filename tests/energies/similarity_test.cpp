// SimilarityEnergy (pose capture): a similar copy of the template is a fixed point with
// zero energy; from any positions the proposal is a similar (rigid: congruent) copy of the
// template, it is the closest one (no similarity nearby does better), and the rigid variant keeps
// the template's size; free vertices get no proposal; 1 and 2 threads agree.
#include "energies/similarity.h"
#include "framework/core/errors.h"
#include "tests/energy_fixtures.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <omp.h>
#include <random>

namespace dsnake {
namespace {

using test_support::make_energy;
using test_support::perturbed;
using test_support::wobbly_polygon;
using test_support::wobbly_sphere;

template <int D>
Eigen::Matrix<double, D, D> rotation(double angle_rad) {
  if constexpr (D == 2) return Eigen::Rotation2Dd(angle_rad).toRotationMatrix();
  else return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
}

template <int D>
double sum_squared(const PointList<D>& a, const PointList<D>& b) {
  double e = 0;
  for (size_t i = 0; i < a.size(); ++i) e += (a[i] - b[i]).squaredNorm();
  return e;
}

// The best similarity (or rigid motion) of p onto `out`, by least squares: its residual.
template <int D>
double distance_to_similar_copy(const PointList<D>& p, const PointList<D>& out, bool rigid) {
  const auto m = Eigen::umeyama(Eigen::Map<const Eigen::Matrix<double, D, Eigen::Dynamic>>(p[0].data(), D, p.size()),
                                Eigen::Map<const Eigen::Matrix<double, D, Eigen::Dynamic>>(out[0].data(), D, out.size()),
                                !rigid);
  double e = 0;
  for (size_t i = 0; i < p.size(); ++i)
    e += ((m.template topLeftCorner<D, D>() * p[i] + m.template topRightCorner<D, 1>()) - out[i]).squaredNorm();
  return e;
}

template <int D>
void check_similarity_energy(const Template<D>& t) {
  for (const char* transform : {"similarity", "rigid"}) {
    SCOPED_TRACE(std::string(std::to_string(D)) + "D " + transform);
    const bool rigid = transform == std::string("rigid");
    auto e = make_energy<D>(std::string(R"({"type": "similarity", "transform": ")") + transform + "\"}");
    const double scale = rigid ? 1.0 : 1.7;
    Point<D> shift = Point<D>::Constant(3.0);
    PointList<D> q;
    for (const auto& p : t.positions) q.push_back(scale * rotation<D>(0.6) * p + shift);
    Snake<D> s = Snake<D>::from_template(t, q);
    e->bind({&t}, s);
    PointList<D> out(q.size());
    e->propose(s, out);
    EXPECT_LT(sum_squared<D>(out, q), 1e-18 * q.size());  // a similar copy stays
    EXPECT_LT(e->value(s), 1e-18 * q.size());
    // deformed positions: the proposal is a similar copy, the closest one
    s.positions() = perturbed<D>(q, 1.5, 4);
    e->propose(s, out);
    EXPECT_LT(distance_to_similar_copy<D>(t.positions, out, rigid), 1e-16 * q.size());
    const double best = sum_squared<D>(out, s.positions());
    EXPECT_NEAR(e->value(s), best, 1e-9 * best);
    EXPECT_NEAR(distance_to_similar_copy<D>(t.positions, s.positions(), rigid), best, 1e-9 * best);
    if (rigid) {  // congruent: pairwise distances kept
      EXPECT_NEAR((out[0] - out[5]).norm(), (t.positions[0] - t.positions[5]).norm(), 1e-9);
    }
    // 1 and 2 threads
    PointList<D> one(q.size()), two(q.size());
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    e->propose(s, one);
    omp_set_num_threads(2);
    e->propose(s, two);
    omp_set_num_threads(saved);
    for (size_t v = 0; v < q.size(); ++v) EXPECT_EQ(one[v], two[v]);
  }
}

TEST(SimilarityEnergy, ProposesTheClosestSimilarCopy2d) { check_similarity_energy<2>(wobbly_polygon(40)); }
TEST(SimilarityEnergy, ProposesTheClosestSimilarCopy3d) { check_similarity_energy<3>(wobbly_sphere(2)); }

// Free vertices (inserted by a remesh) get no proposal; the template vertices are fitted alone.
TEST(SimilarityEnergy, FreeVerticesGetNoProposal) {
  const Template<2> t = wobbly_polygon(8);
  auto e = make_energy<2>(R"({"type": "similarity"})");
  PointList<2> q;
  std::vector<int> ids;
  for (int i = 0; i < 8; ++i) {
    q.push_back(0.5 * t.positions[i] + Point<2>(1, 2));
    ids.push_back(i);
    q.push_back(Point<2>(50, 50));  // far away: must not enter the fit
    ids.push_back(-1);
  }
  Snake<2> s(q, Connectivity::polygon(16), ids);
  e->bind({&t}, s);
  PointList<2> out(16, Point<2>(99, 99));
  e->propose(s, out);
  for (int v = 0; v < 16; ++v) {
    if (ids[v] < 0) EXPECT_EQ(out[v], Point<2>(99, 99));
    else EXPECT_LT((out[v] - q[v]).norm(), 1e-9);
  }
  EXPECT_FALSE(e->has_least_squares_form());
}

TEST(SimilarityEnergy, BadTransformNamesTheKey) {
  try {
    make_energy<3>(R"({"type": "similarity", "transform": "affine"})");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "energies[0].transform");
  }
}

}  // namespace
}  // namespace dsnake
