// "template.start": the snake starts at a file's positions (another registration's result
// carrying the template's vertices) while the rest positions, where the atlas is sampled, stay
// the template's. A contour template on the outer edge of a ring image (the reference), a target
// that is the ring moved by (2, -2) mm with another contrast: started at the template moved onto
// the target's edge, the profile force keeps every vertex where it starts (its expected profile
// comes from the reference at the template's position). And the key's problems, by JSON path.
#include "experiments/output/provenance.h"
#include "experiments/output/runner.h"
#include "tests/experiments/spec/ring_case_test.h"
#include "tests/test_meshes.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace dsnake {
namespace {

using namespace test_support;

class TemplateStartTest : public RingCaseTest {
 protected:
  // The ring case started at the template moved onto the target's edge (start.txt).
  nlohmann::ordered_json write_case() {
    nlohmann::ordered_json j = write_ring_case("template_start");
    tmpl_ = ring_template();
    start_ = tmpl_;
    for (Point<2>& p : start_) p += kRingShift;
    write_contour(start_, (dir_ / "start.txt").string());
    j["template"]["start"] = "start.txt";
    return j;
  }
  PointList<2> tmpl_, start_;
};

double max_distance(const PointList<2>& a, const PointList<2>& b) {
  double d = 0.0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, (a[i] - b[i]).norm());
  return d;
}

// The run starts at the file's positions (initial.txt), its rest positions are the template's,
// and the start on the target's edge is a fixed point of the profile force: every vertex ends
// within 0.1 mm of where it started (from the template itself, 2.8 mm away, the same run moves
// the vertices by more than 1 mm on average: along their normals, 2.8 |cos| mm).
TEST_F(TemplateStartTest, TheSnakeStartsAtTheFileAndRestsOnTheTemplate) {
  const nlohmann::ordered_json j = write_case();
  Experiment<2> ex = make_experiment<2>(file_of(j));
  EXPECT_LT(max_distance(ex.tmpl.positions, tmpl_), 1e-9);
  const auto result = run_experiment(ex, RunOptions{(dir_ / "out").string(), true});
  // An input like the others: its SHA-256 in the provenance (a sweep reruns a run whose start changed).
  EXPECT_EQ(result["provenance"]["inputs"]["template.start"]["sha256"].get<std::string>(),
            file_sha256((dir_ / "start.txt").string()));
  const PointList<2> initial = read_contour_template((dir_ / "out" / "initial.txt").string()).positions;
  const PointList<2> final = read_contour_template((dir_ / "out" / "final.txt").string()).positions;
  ASSERT_EQ(initial.size(), start_.size());
  ASSERT_EQ(final.size(), start_.size());
  EXPECT_LT(max_distance(initial, start_), 1e-6);
  const double moved = max_distance(final, start_);
  std::printf("started at the target's edge: largest move %.3f mm\n", moved);
  EXPECT_LT(moved, 0.1);

  nlohmann::ordered_json k = write_case();
  k["template"].erase("start");
  Experiment<2> from_template = make_experiment<2>(file_of(k));
  run_experiment(from_template, RunOptions{(dir_ / "out2").string(), true});
  const PointList<2> final2 = read_contour_template((dir_ / "out2" / "final.txt").string()).positions;
  double mean = 0.0;
  for (size_t i = 0; i < tmpl_.size(); ++i) mean += (final2[i] - tmpl_[i]).norm() / double(tmpl_.size());
  EXPECT_GT(mean, 1.0);
}

TEST_F(TemplateStartTest, ProblemsNameTheKey) {
  nlohmann::ordered_json j = write_case();
  j["template"]["start"] = "missing.txt";
  EXPECT_EQ(error_path(j), "template.start");
  j["template"]["start"] = "";
  EXPECT_EQ(error_path(j), "template.start");
  j["template"]["start"] = 3;
  EXPECT_EQ(error_path(j), "template.start");
  // another vertex count
  j = write_case();
  write_contour(round_template<2>(14.0, kRingShift, 41).positions, (dir_ / "start.txt").string());
  EXPECT_EQ(error_path(j), "template.start");
  // a start far outside the image (the template itself inside it)
  j = write_case();
  {
    PointList<2> far = start_;
    for (Point<2>& p : far) p += Point<2>(500.0, 0.0);
    write_contour(far, (dir_ / "start.txt").string());
  }
  EXPECT_EQ(error_path(j), "template.start");
  // with a placement or an init, one of them would be ignored
  j = write_case();
  j["template"]["transform"] = {{"scale", 1.1}};
  EXPECT_EQ(error_path(j), "template.start");
  j = write_case();
  j["template"]["init"] = {{"type", "image"}};
  EXPECT_EQ(error_path(j), "template.start");
  j = write_case();
  EXPECT_EQ(error_path(j), "");
}

// 3D: the start must keep the template's faces; the same faces listed in another order, each
// from another corner, are the same mesh.
TEST_F(TemplateStartTest, AMeshStartKeepsTheTemplatesFaces) {
  const Snake<3> sphere = test::icosphere(2, 10.0);
  write_image<3>(radial_image<3>(40, 1.0, [](double r) { return r < 10 ? 200.0 : 50.0; }, 1.0), (dir_ / "ball.mha").string());
  write_mesh(sphere.positions(), sphere.connectivity(), (dir_ / "template.off").string());
  nlohmann::ordered_json j = {{"name", "start3d"}, {"dimension", 3},
                              {"image", {{"file", "ball.mha"}}},
                              {"template", {{"file", "template.off"}, {"start", "start.off"}}},
                              {"field", {{"type", "gradient"}}},
                              {"energies", {{{"type", "internal"}, {"weight", 1.0}}}},
                              {"phases", {{{"iterations", 1}}}}};
  PointList<3> moved = sphere.positions();
  for (Point<3>& p : moved) p *= 1.05;
  std::vector<Triangle> faces = sphere.connectivity().triangles();
  std::reverse(faces.begin(), faces.end());
  for (Triangle& t : faces) std::rotate(t.begin(), t.begin() + 1, t.end());
  write_mesh(moved, Connectivity::mesh(int(moved.size()), faces), (dir_ / "start.off").string());
  EXPECT_EQ(error_path<3>(j), "");
  Experiment<3> ex = make_experiment<3>(file_of(j));
  EXPECT_NEAR((ex.image.grid().to_world(ex.initial[0]) - moved[0]).norm(), 0.0, 1e-6);
  // one face turned over (its orientation flipped), and a mesh with other faces
  faces[0] = {faces[0][0], faces[0][2], faces[0][1]};
  write_mesh(moved, Connectivity::mesh(int(moved.size()), faces), (dir_ / "start.off").string());
  EXPECT_EQ(error_path<3>(j), "template.start");
  const Snake<3> other = test::icosphere(1, 10.0);
  write_mesh(other.positions(), other.connectivity(), (dir_ / "start.off").string());
  EXPECT_EQ(error_path<3>(j), "template.start");
}

}  // namespace
}  // namespace dsnake
