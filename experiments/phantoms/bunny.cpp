#include "experiments/phantoms/bunny.h"

#include "experiments/phantoms/phantoms.h"
#include "framework/core/errors.h"
#include "framework/io/mesh_io.h"
#include "meshing/mesh_processing.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

namespace dsnake {

namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr int kUp = 1;  // the Stanford bunny's up axis (y)

// Default centre of a "mesh" image of this fit (its default size fit + 16, cubic), shared by the
// "bunny" template so that both default to the same place.
Point<3> default_mesh_center(double fit) {
  return Point<3>::Constant(0.5 * (std::ceil(fit) + 16 - 1));
}

// Heights of the template's lowest and highest vertex and of the ears' base (fraction ear_base).
struct Heights {
  double bottom, top, base;
};
Heights heights(const PointList<3>& p, double ear_base) {
  Heights h{std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(), 0};
  for (const auto& x : p) {
    h.bottom = std::min(h.bottom, x[kUp]);
    h.top = std::max(h.top, x[kUp]);
  }
  h.base = h.bottom + ear_base * (h.top - h.bottom);
  return h;
}

// The twist angle (radians) at height y: 0 up to the ears' base, growing linearly to the top.
double twist_angle(double y, const Heights& h, double twist_deg) {
  if (h.top <= h.base) return 0;
  return twist_deg * kPi / 180.0 * std::clamp((y - h.base) / (h.top - h.base), 0.0, 1.0);
}

// x turned by angle about the vertical line through a.
Point<3> turn(const Point<3>& x, const Point<3>& a, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  const Point<3> d = x - a;
  return a + Point<3>(c * d.x() + s * d.z(), d.y(), -s * d.x() + c * d.z());
}

}  // namespace

Template<3> load_fitted_mesh(const std::string& path, double fit, const Point<3>& center) {
  Template<3> t = read_mesh_template(path);  // closed, manifold, outward (mesh_io.h)
  Point<3> lo = t.positions[0], hi = t.positions[0];
  for (const auto& p : t.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double longest = (hi - lo).maxCoeff();
  if (!(longest > 0)) throw InputError(path, "", "the mesh is flat (zero bounding box)");
  const Point<3> mid = 0.5 * (lo + hi);
  for (auto& p : t.positions) p = center + (fit / longest) * (p - mid);
  return t;
}

// A relative "mesh" path is relative to the experiment file's folder (as image and template
// files are); a missing file names the key and the fetch script.
void MeshPathKey::resolve(std::optional<std::string>& path, const JsonReader& r) {
  if (!path) r.fail("mesh", "is required");
  std::string& p = *path;
  r.expect(!p.empty(), "mesh", "must be a mesh file path");
  const std::string& file = r.file();
  if (fs::path(p).is_relative() && !file.empty() && file.rfind("builtin:", 0) != 0)
    p = (fs::path(file).parent_path() / p).string();
  r.expect(fs::exists(p), "mesh",
           "no such mesh file \"" + p + "\" (the bunny comes from scripts/fetch_bunny.sh, run by scripts/setup.sh)");
}

void PointsImageOptions::check() const {
  canvas.check();
  if (!centers) throw OptionError{"centers", "is required: [[x, y, z], ...]"};
}

// Fig. 1: small solid balls, one closed icosphere each, in one (disconnected) surface.
Template<3> points_surface(const PointsImageOptions& o) {
  const Template<3> ball = make_icosphere(2);
  Template<3> out;
  std::vector<Triangle> tris;
  for (const Point<3>& x : *o.centers) {
    const int offset = out.num_vertices();
    for (const auto& p : ball.positions) out.positions.push_back(x + o.radius * p);
    for (Triangle t : ball.connectivity.triangles()) {
      for (int& v : t) v += offset;
      tris.push_back(t);
    }
  }
  out.connectivity = Connectivity::mesh(out.num_vertices(), std::move(tris));
  return out;
}

Point<3> BunnyTemplateOptions::center_point() const { return center ? *center : default_mesh_center(fit); }

Template<3> simplify_mesh_quadric(const Template<3>& t, int vertices) {
  DecimatedMesh m = simplify_quadric(t.positions, t.connectivity, vertices);
  Template<3> out;
  out.positions = std::move(m.points);
  out.connectivity = std::move(m.connectivity);
  return out;
}

void deform_bunny(Template<3>& t, const Point<3>& center, const BunnyDeformation& d) {
  for (auto& p : t.positions) p = center + d.stretch.cwiseProduct(p - center);
  const Heights h = heights(t.positions, d.ear_base);
  // The twist axis: the vertex at or below the ears' base nearest (in x, z) to the ears' centroid.
  Point<3> ears = Point<3>::Zero();
  int n = 0;
  for (const auto& p : t.positions)
    if (p[kUp] > h.base) ears += p, ++n;
  if (n > 0) ears /= n;
  int axis = -1;
  double best = std::numeric_limits<double>::max();
  for (int v = 0; v < t.num_vertices(); ++v) {
    const Point<3>& p = t.positions[v];
    const double d2 = std::pow(p.x() - ears.x(), 2) + std::pow(p.z() - ears.z(), 2);
    if (p[kUp] <= h.base && d2 < best) best = d2, axis = v;
  }
  DSNAKE_ASSERT(axis >= 0, "a vertex at or below the ears' base");
  t.landmarks["ear_axis"] = axis;
  const Point<3> a = t.positions[axis];
  for (auto& p : t.positions) p = turn(p, a, twist_angle(p[kUp], h, d.ear_twist_deg));
}

PointList<3> undeform_bunny(const Template<3>& t, const Point<3>& center, const BunnyDeformation& d) {
  // The twist keeps heights and the axis vertex: undo it, then the scaling.
  const Heights h = heights(t.positions, d.ear_base);
  const auto it = t.landmarks.find("ear_axis");
  DSNAKE_ASSERT(it != t.landmarks.end(), "bunny template has its ear_axis landmark");
  const Point<3> a = t.positions[it->second];
  PointList<3> out;
  for (const auto& p : t.positions)
    out.push_back(center + (turn(p, a, -twist_angle(p[kUp], h, d.ear_twist_deg)) - center).cwiseQuotient(d.stretch));
  return out;
}

Template<3> make_bunny_template(const BunnyTemplateOptions& o) {
  const Point<3> center = o.center_point();
  Template<3> t = simplify_mesh_quadric(load_fitted_mesh(*o.mesh, o.fit, center), o.vertices);
  deform_bunny(t, center, o.deformation);
  return t;
}

std::vector<std::optional<Point<3>>> bunny_targets(const BunnyTemplateOptions& o, const Template<3>& t) {
  std::vector<std::optional<Point<3>>> targets;
  for (const auto& p : undeform_bunny(t, o.center_point(), o.deformation)) targets.emplace_back(p);
  return targets;
}

}  // namespace dsnake
