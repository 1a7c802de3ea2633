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

// A relative "mesh" path is relative to the experiment file's folder (as image and template
// files are, experiments/experiment.cpp); a missing file names the key and the fetch script.
std::string read_mesh_path(JsonReader& r) {
  std::string p;
  r.require("mesh", p);
  r.expect(!p.empty(), "mesh", "must be a mesh file path");
  const std::string& file = r.file();
  if (fs::path(p).is_relative() && !file.empty() && file.rfind("builtin:", 0) != 0)
    p = (fs::path(file).parent_path() / p).string();
  r.expect(fs::exists(p), "mesh",
           "no such mesh file \"" + p + "\" (the bunny comes from scripts/fetch_bunny.sh, run by scripts/setup.sh)");
  return p;
}

double read_fit(JsonReader& r) {
  double fit = 64;
  r.read("fit", fit);
  r.expect(fit > 0 && fit <= 4096, "fit", "must be in (0, 4096]");
  return fit;
}

// Default centre of a "mesh" image of this fit (its default size fit + 16, cubic), shared by the
// "bunny" template so that both default to the same place.
Point<3> default_mesh_center(double fit) {
  return Point<3>::Constant(0.5 * (std::ceil(fit) + 16 - 1));
}

Point<3> read_center(JsonReader& r, double fit) {
  Point<3> center = default_mesh_center(fit);
  r.read<3>("center", center);
  return center;
}

BunnyDeformation read_deformation(JsonReader& r) {
  BunnyDeformation d;
  r.read<3>("stretch", d.stretch);
  r.expect(d.stretch.minCoeff() > 0, "stretch", "must be > 0 on every axis");
  r.read("ear_twist_deg", d.ear_twist_deg);
  r.expect(std::abs(d.ear_twist_deg) <= 180, "ear_twist_deg", "must be in [-180, 180]");
  r.read("ear_base", d.ear_base);
  r.expect(d.ear_base >= 0 && d.ear_base < 1, "ear_base", "must be in [0, 1)");
  return d;
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

GridIndex<3> mesh_image_size(JsonReader& r, const std::string& kind) {
  if (kind == "mesh") return GridIndex<3>::Constant(int(std::ceil(read_fit(r))) + 16);
  if (kind == "points") return GridIndex<3>::Constant(64);
  return GridIndex<3>::Zero();
}

std::optional<Template<3>> make_mesh_image_surface(JsonReader& r, const std::string& kind, const Point<3>& center) {
  if (kind == "mesh") return load_fitted_mesh(read_mesh_path(r), read_fit(r), center);
  if (kind != "points") return std::nullopt;
  // Fig. 1: small solid balls, one closed icosphere each, in one (disconnected) surface.
  double radius = 3;
  r.read("radius", radius);
  r.expect(radius > 0, "radius", "must be > 0");
  r.expect(r.has("centers"), "centers", "is required: [[x, y, z], ...]");
  const nlohmann::json& list = r.raw("centers");
  r.expect(list.is_array() && !list.empty(), "centers", "expected a non-empty array of [x, y, z]");
  const Template<3> ball = make_icosphere(2);
  Template<3> out;
  std::vector<Triangle> tris;
  for (const auto& c : list) {
    if (!c.is_array() || c.size() != 3 || !c[0].is_number() || !c[1].is_number() || !c[2].is_number())
      r.fail("centers", "expected an array of [x, y, z] points");
    const Point<3> x(c[0].get<double>(), c[1].get<double>(), c[2].get<double>());
    const int offset = out.num_vertices();
    for (const auto& p : ball.positions) out.positions.push_back(x + radius * p);
    for (Triangle t : ball.connectivity.triangles()) {
      for (int& v : t) v += offset;
      tris.push_back(t);
    }
  }
  out.connectivity = Connectivity::mesh(out.num_vertices(), std::move(tris));
  return out;
}

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

std::optional<Template<3>> make_bunny_template(JsonReader& r, const std::string& kind) {
  if (kind != "bunny") return std::nullopt;
  const double fit = read_fit(r);
  const Point<3> center = read_center(r, fit);
  int vertices = 358;
  r.read("vertices", vertices);
  r.expect(vertices >= 8 && vertices <= 1000000, "vertices", "must be in [8, 1000000]");
  const BunnyDeformation d = read_deformation(r);
  const std::string path = read_mesh_path(r);  // last: the parameters are checked first
  Template<3> t = simplify_mesh_quadric(load_fitted_mesh(path, fit, center), vertices);
  deform_bunny(t, center, d);
  return t;
}

std::vector<std::optional<Point<3>>> bunny_targets(JsonReader& r, const Template<3>& t) {
  const Point<3> center = read_center(r, read_fit(r));
  std::vector<std::optional<Point<3>>> targets;
  for (const auto& p : undeform_bunny(t, center, read_deformation(r))) targets.emplace_back(p);
  return targets;
}

}  // namespace dsnake
