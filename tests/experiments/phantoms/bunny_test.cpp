// The bunny of Levi & Gotsman's D-Snake (Fig. 10), the three attracting points (Fig. 1) and the
// genus-2 bone (Figs. 11-12): the bunny converter of scripts/fetch_bunny.sh on hand-written
// index.js files (no network), the "mesh" and "points" image phantoms and the "bunny" template
// (experiments/phantoms/bunny.h) on small closed meshes, and reduced runs of experiments/paper/
// {three_points,bone,bunny}_*.json through the dsnake executable that assert the direction of the
// results of REPRODUCTION.md (Figures 1, 10, 11-12).
#include "experiments/phantoms/bunny.h"
#include "experiments/phantoms/paper_phantoms.h"
#include "experiments/phantoms/phantoms.h"
#include "tests/experiments/phantoms/phantom_test_support.h"
#include "framework/io/mesh_io.h"

#include <Eigen/Geometry>
#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace dsnake {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
constexpr double kPi = 3.14159265358979323846;

class BunnyTest : public test_support::TempDirTest {
 protected:

  static int shell(const std::string& cmd) {
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  // Runs experiments/paper/<file> with the --set overrides, one thread, no figures; result.json.
  json run(const std::string& file, const std::vector<std::string>& sets, int exit_code = 0) {
    const fs::path out = dir_ / ("run" + std::to_string(runs_++)), err = dir_ / "stderr.txt";
    std::string cmd = std::string(DSNAKE_EXE) + " run " + std::string(DSNAKE_SOURCE_DIR) + "/experiments/paper/" + file +
                      " --out " + out.string() + " --quiet -j 1 --set output.figures=false";
    for (const auto& s : sets) cmd += " --set '" + s + "'";
    EXPECT_EQ(shell(cmd + " 2>" + err.string()), exit_code) << cmd << "\n" << slurp(err);
    std::ifstream in(out / "result.json");
    if (!in) {
      ADD_FAILURE() << "no result.json: " << cmd;
      return json{{"metrics", json::object()}};
    }
    return json::parse(in);
  }

  int runs_ = 0;
};

// V - E + F and "every edge in exactly two triangles" of a triangle list.
struct MeshCheck {
  bool closed = true;
  int euler = 0;
};
MeshCheck check_mesh(int vertices, const std::vector<Triangle>& tris) {
  std::map<std::pair<int, int>, int> edges;
  for (const auto& t : tris)
    for (int k = 0; k < 3; ++k) ++edges[std::minmax(t[k], t[(k + 1) % 3])];
  MeshCheck c;
  for (const auto& [e, n] : edges) c.closed = c.closed && n == 2;
  c.euler = vertices - int(edges.size()) + int(tris.size());
  return c;
}

// Signed volume (divergence theorem): positive for an outward closed mesh.
double signed_volume(const PointList<3>& p, const std::vector<Triangle>& tris) {
  double v = 0;
  for (const auto& t : tris) v += p[t[0]].dot(p[t[1]].cross(p[t[2]])) / 6.0;
  return v;
}

void write_off(const Template<3>& t, const fs::path& path) {
  write_mesh(t.positions, t.connectivity, path.string());
}

// The converter closes each boundary loop of a hand-written index.js with a fan about its centroid,
// oriented like the rest: an octahedron without its faces (0,2,4) and (1,3,5) (two disjoint
// triangular holes) becomes a closed outward mesh of 8 vertices and 12 triangles.
TEST_F(BunnyTest, ConverterClosesHolesOutward) {
  const fs::path js = dir_ / "index.js", off = dir_ / "out" / "bunny.off";
  // Octahedron: 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z; outward faces, minus (0,2,4) and (1,3,5).
  std::ofstream(js) << "exports.positions=[[1,0,0],[-1,0,0],[0,1,0],[0,-1,0],[0,0,1],[0,0,-1]];\n"
                       "exports.cells=[[2,1,4],[1,3,4],[3,0,4],[0,5,2],[2,5,1],[3,5,0]]\n";
  const std::string script = std::string(DSNAKE_SOURCE_DIR) + "/scripts/fetch_bunny.sh";
  ASSERT_EQ(shell(script + " --from-index " + js.string() + " " + off.string() + " >/dev/null"), 0);
  std::ifstream in(off);
  std::string magic;
  int nv, nf, ne;
  in >> magic >> nv >> nf >> ne;
  ASSERT_EQ(magic, "OFF");
  ASSERT_EQ(nv, 8);
  ASSERT_EQ(nf, 12);
  PointList<3> p(nv);
  for (auto& x : p) in >> x[0] >> x[1] >> x[2];
  std::vector<Triangle> tris(nf);
  for (auto& t : tris) {
    int three;
    in >> three >> t[0] >> t[1] >> t[2];
    ASSERT_EQ(three, 3);
  }
  const MeshCheck c = check_mesh(nv, tris);
  EXPECT_TRUE(c.closed);
  EXPECT_EQ(c.euler, 2);
  // The new vertices are the holes' centroids; the closed octahedron's volume is 4/3, the two
  // flat fans add nothing.
  std::set<std::vector<double>> centres;
  for (int v = 6; v < 8; ++v) centres.insert({std::round(p[v].x() * 3), std::round(p[v].y() * 3), std::round(p[v].z() * 3)});
  for (int v = 6; v < 8; ++v) EXPECT_NEAR(std::abs(p[v].x()), 1.0 / 3.0, 1e-8);
  EXPECT_EQ(centres, (std::set<std::vector<double>>{{1, 1, 1}, {-1, -1, -1}}));
  EXPECT_NEAR(signed_volume(p, tris), 4.0 / 3.0, 1e-6);
  EXPECT_NO_THROW(read_mesh_template(off.string()));
  // Bad input: an index out of range fails with a message, and writes nothing.
  std::ofstream(js) << "exports.positions=[[1,0,0],[0,1,0],[0,0,1]];\nexports.cells=[[0,1,7]]\n";
  const fs::path bad = dir_ / "bad.off";
  EXPECT_NE(shell(script + " --from-index " + js.string() + " " + bad.string() + " 2>/dev/null"), 0);
  EXPECT_FALSE(fs::exists(bad));
}

// "mesh" image phantom: a unit icosphere fitted to 32 voxels about the image centre; the mask
// volume matches the mesh volume within 3%, the surface is the scaled mesh.
TEST_F(BunnyTest, MeshImagePhantomMatchesTheMeshVolume) {
  write_off(make_icosphere(3), dir_ / "sphere.off");
  json spec = {{"phantom", "mesh"}, {"mesh", "sphere.off"}, {"fit", 32}};
  JsonReader r(spec, (dir_ / "experiment.json").string(), "image");  // relative to this file
  const Phantom<3> ph = make_phantom<3>(r);
  r.finish();
  ASSERT_EQ(ph.image.grid().size, GridIndex<3>(48, 48, 48));  // fit + 16
  const Point<3> center = Point<3>::Constant(23.5);
  Point<3> lo = ph.surface.positions[0], hi = lo;
  for (const auto& x : ph.surface.positions) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  EXPECT_NEAR((hi - lo).maxCoeff(), 32.0, 1e-9);
  EXPECT_NEAR((0.5 * (lo + hi) - center).norm(), 0.0, 1e-9);
  const double volume = signed_volume(ph.surface.positions, ph.surface.connectivity.triangles());
  double mask = 0, dark = 0;
  for (int64_t l = 0; l < ph.mask.grid().num_voxels(); ++l) {
    mask += ph.mask[l];
    dark += ph.image[l] == 85.0f;
  }
  EXPECT_NEAR(mask / volume, 1.0, 0.03);
  EXPECT_EQ(dark, mask);  // binary image: foreground 85 exactly on the mask
}

// "points": three balls of radius 5 (icospheres of 162 vertices, inscribed in the sphere, at most
// 0.1 voxel inside it): the mask holds every voxel centre closer than 0.97 r to a centre, and
// none farther than r.
TEST_F(BunnyTest, PointsPhantomHasThreeBalls) {
  json spec = {{"phantom", "points"}, {"centers", {{20, 20, 20}, {40, 20, 30}, {30, 44, 30}}}, {"radius", 5}};
  JsonReader r(spec, "", "image");
  const Phantom<3> ph = make_phantom<3>(r);
  r.finish();
  const PointList<3> centres = {{20, 20, 20}, {40, 20, 30}, {30, 44, 30}};
  int checked = 0;
  for (int64_t l = 0; l < ph.mask.grid().num_voxels(); ++l) {
    const Point<3> x = ph.mask.grid().to_physical(ph.mask.grid().index(l));
    double d = 1e9;
    for (const auto& c : centres) d = std::min(d, (x - c).norm());
    if (d < 0.97 * 5) {
      EXPECT_EQ(ph.mask[l], 1.0f) << x.transpose();
      ++checked;
    }
    if (d > 5) {
      EXPECT_EQ(ph.mask[l], 0.0f) << x.transpose();
    }
  }
  EXPECT_EQ(checked, 3 * 461);  // lattice points with |x|^2 < 4.85^2 per ball
  EXPECT_EQ(ph.surface.num_vertices(), 3 * 162);
  EXPECT_EQ(ph.mask.at(GridIndex<3>(40, 20, 30)), 1.0f);
  EXPECT_EQ(ph.mask.at(GridIndex<3>(30, 30, 30)), 0.0f);
}

// Quadric simplification keeps a subset of the original vertices and a closed genus-0 mesh.
TEST_F(BunnyTest, SimplificationKeepsOriginalVerticesAndClosure) {
  const Template<3> sphere = make_icosphere(4);  // 2562 vertices
  const Template<3> s = simplify_mesh_quadric(sphere, 358);
  EXPECT_NEAR(s.num_vertices(), 358, 358 * 0.02);
  const MeshCheck c = check_mesh(s.num_vertices(), s.connectivity.triangles());
  EXPECT_TRUE(c.closed);
  EXPECT_EQ(c.euler, 2);
  EXPECT_GT(signed_volume(s.positions, s.connectivity.triangles()), 0.9 * 4.0 / 3.0 * kPi);
  std::set<std::vector<double>> original;
  for (const auto& x : sphere.positions) original.insert({x[0], x[1], x[2]});
  for (const auto& x : s.positions) EXPECT_TRUE(original.count({x[0], x[1], x[2]}));
}

// The "bunny" template on an elongated icosphere (an ellipsoid standing on +y): closed, about
// `vertices` vertices; its targets (through phantom_targets, as the experiment computes them) are
// the undeformed positions (the template with no stretch and no twist); the "ear_axis" vertex
// keeps its x, z; the top vertex turns by ear_twist_deg about it.
TEST_F(BunnyTest, BunnyTemplateTargetsAreTheUndeformedPositions) {
  Template<3> egg = make_icosphere(4);
  for (auto& x : egg.positions) x = x.cwiseProduct(Point<3>(1.0, 2.0, 0.8));
  write_off(egg, dir_ / "egg.off");
  json spec = {{"phantom", "bunny"}, {"mesh", (dir_ / "egg.off").string()}, {"fit", 40}, {"vertices", 200},
               {"stretch", {1.1, 0.95, 1.0}}, {"ear_twist_deg", 20}, {"ear_base", 0.7}};
  JsonReader r(spec, "", "template");
  const Template<3> t = make_template_phantom<3>(r);
  r.finish();
  json plain = spec;
  plain["stretch"] = {1.0, 1.0, 1.0};
  plain["ear_twist_deg"] = 0;
  JsonReader rp(plain, "", "template");
  const Template<3> u = make_template_phantom<3>(rp);
  ASSERT_EQ(t.num_vertices(), u.num_vertices());
  EXPECT_NEAR(t.num_vertices(), 200, 4);
  const MeshCheck c = check_mesh(t.num_vertices(), t.connectivity.triangles());
  EXPECT_TRUE(c.closed);
  EXPECT_EQ(c.euler, 2);

  const json image = {{"phantom", "mesh"}, {"mesh", (dir_ / "egg.off").string()}, {"fit", 40}};
  const auto targets = targets_of<3>(image, spec, t);
  ASSERT_EQ(int(targets.size()), t.num_vertices());
  double moved = 0;
  for (int k = 0; k < t.num_vertices(); ++k) {
    ASSERT_TRUE(targets[k].has_value());
    EXPECT_NEAR((*targets[k] - u.positions[k]).norm(), 0.0, 1e-9) << k;
    moved = std::max(moved, (t.positions[k] - u.positions[k]).norm());
  }
  EXPECT_GT(moved, 2.0);  // a real deformation: the stretch alone moves the tip by 0.05 * 40 = 2
  // Stretch about the centre (27.5 = (40 + 16 - 1) / 2), then the twist about the ear axis.
  const Point<3> center = Point<3>::Constant(27.5), stretch(1.1, 0.95, 1.0);
  const int axis = t.landmarks.at("ear_axis");
  const Point<3> a = center + stretch.cwiseProduct(u.positions[axis] - center);
  EXPECT_NEAR((t.positions[axis] - a).norm(), 0.0, 1e-9);
  // Every vertex turns about the axis by 20 deg * clamp((y - y_b) / (y_top - y_b), 0, 1), y_b at
  // 70% of the stretched heights.
  double bottom = 1e9, top = -1e9;
  for (const auto& x : u.positions) bottom = std::min(bottom, center.y() + 0.95 * (x.y() - center.y())),
                                    top = std::max(top, center.y() + 0.95 * (x.y() - center.y()));
  const double base = bottom + 0.7 * (top - bottom);
  int turned = 0;
  for (int k = 0; k < t.num_vertices(); ++k) {
    const Point<3> s = center + stretch.cwiseProduct(u.positions[k] - center);
    const Point<3> d0 = s - a, d1 = t.positions[k] - a;
    EXPECT_NEAR(d1.y(), d0.y(), 1e-9);
    if (std::hypot(d0.x(), d0.z()) < 1) continue;
    const double angle = std::atan2(d0.z() * d1.x() - d0.x() * d1.z(), d0.x() * d1.x() + d0.z() * d1.z()) * 180 / kPi;
    EXPECT_NEAR(angle, 20.0 * std::clamp((s.y() - base) / (top - base), 0.0, 1.0), 1e-6) << k;
    turned += angle > 10;
  }
  EXPECT_GT(turned, 5);
}

// Fig. 10, reduced, on a stand-in mesh (the tests do not download the bunny): the 3D star (386
// vertices, its +y arm the "ears") as the "mesh" image (fit 48, 64^3) and as the "bunny" template
// (200 vertices, the same stretch and twist), 150 iterations. As on the bunny, the D-Snake keeps
// the arms and the correspondence; the DDGVF snake from the refined template loses both.
TEST_F(BunnyTest, BunnyStandInDSnakeBeatsDdgvf) {
  const Template<3> star = make_star3d(Point<3>::Zero(), Star3dShape{30, 12}, 2);
  write_off(star, dir_ / "star.off");
  const std::string mesh = (dir_ / "star.off").string();
  auto sets = [&](int fit_phase) {
    return std::vector<std::string>{"image.mesh=" + mesh, "template.mesh=" + mesh, "image.fit=48", "template.fit=48",
                                    "image.size=[64,64,64]", "template.center=[31.5,31.5,31.5]", "template.vertices=200",
                                    "phases[" + std::to_string(fit_phase) + "].iterations=150"};
  };
  const json d = run("bunny_dsnake.json", sets(0)), c = run("bunny_ddgvf.json", sets(1));
  const auto& md = d["metrics"];
  const auto& mc = c["metrics"];
  EXPECT_LT(md["correspondence_error_mean"].get<double>(), 0.5 * mc["correspondence_error_mean"].get<double>());
  EXPECT_LT(md["correspondence_error_max"].get<double>(), mc["correspondence_error_max"].get<double>());
  EXPECT_LT(md["mean_surface_distance"].get<double>(), mc["mean_surface_distance"].get<double>());
  EXPECT_GT(md["dice"].get<double>(), mc["dice"].get<double>());
}

// Fig. 1, reduced (150 iterations): the classical snake leaves the sphere (it collapses under
// alpha 0.5, which the watchdog reports: exit code 3, the last state before the collapse written)
// while the D-Snake stays a similarity of the template (REPRODUCTION.md (Figures 1, 10, 11-12)).
TEST_F(BunnyTest, ThreePointsDSnakeStaysSpherical) {
  const json c = run("three_points_classical.json", {"phases[0].iterations=150"}, 3);
  EXPECT_EQ(c["status"], "diverged");
  EXPECT_NE(c["divergence"]["reason"].get<std::string>().find("the snake collapsed"), std::string::npos);
  EXPECT_EQ(c["divergence"]["term"], "energies[0] (internal)");
  EXPECT_LT(c["divergence"]["phase_iteration"].get<int>(), 150);
  EXPECT_GE(c["pose"]["measure_ratio"].get<double>(), 1e-3);  // the last good state
  const json d = run("three_points_dsnake.json", {"phases[0].iterations=150"});
  // Mean surface distance to the 3 balls: the D-Snake keeps its radius 16 shell (about 10 from
  // the balls on average); the classical snake shrinks towards its centre (farther, > 15).
  EXPECT_LT(d["metrics"]["mean_surface_distance"].get<double>(), 12.0);
  EXPECT_GT(c["metrics"]["mean_surface_distance"].get<double>(), 15.0);
}

// Figs. 11-12, reduced (150 + 40 iterations): D-Snake on the genus-2 bone gets within a voxel
// and keeps genus 2 (V - E + F = -2) through the refinement.
TEST_F(BunnyTest, BoneKeepsGenusTwo) {
  const json r = run("bone_dsnake.json", {"phases[0].iterations=150", "phases[1].iterations=40"});
  EXPECT_EQ(r["mesh_quality"]["euler_characteristic"].get<int>(), -2);
  EXPECT_TRUE(r["mesh_quality"]["closed"].get<bool>());
  EXPECT_LT(r["metrics"]["mean_surface_distance"].get<double>(), 1.0);
  EXPECT_GT(r["metrics"]["dice"].get<double>(), 0.9);
  EXPECT_GT(r["vertices"]["final"].get<int>(), r["vertices"]["initial"].get<int>());
}

}  // namespace
}  // namespace dsnake
