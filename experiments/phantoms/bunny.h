// Phantoms from a closed mesh file, for the bunny of Levi & Gotsman's D-Snake (§6, Fig. 10), and
// the three attracting points of Fig. 1. experiments/phantoms/phantoms.cpp dispatches to them; images are
// rendered like the paper phantoms (voxelised interior, background 170, foreground 85, binary
// unless "partial_volume"; "blur" 0 by default).
//  - image "mesh": {"phantom": "mesh", "mesh": PATH, "fit": 64, ...canvas keys}: the closed mesh
//    at PATH (OFF/OBJ/PLY/STL; relative paths are relative to the experiment file's folder),
//    scaled uniformly so that its bounding box's longest side is `fit` (physical units) and its
//    bounding-box centre is at "center" (default: the image centre). Default size: fit + 16
//    voxels per axis (cubic). Ground truth: the scaled mesh and its voxelised interior.
//    ("mesh", not "file": "file" means an image file in an experiment's "image" object.)
//  - image "points": {"phantom": "points", "centers": [[x, y, z], ...], "radius": 3}: solid balls
//    (an icosphere of 162 vertices each: finer ones make the
//    surface-distance metrics slow, as the snake stays far from these small balls) on a 64^3 canvas by default; Fig. 1's attracting points.
//  - template "bunny": {"phantom": "bunny", "mesh": PATH, "fit": 64, "vertices": 358,
//    "stretch": [1.1, 0.95, 1.0], "ear_twist_deg": 20, "ear_base": 0.7, "center"}: the same
//    scaled mesh as the "mesh" image (same PATH, fit and center), simplified to about `vertices`
//    vertices by quadric-error half-edge collapses (OpenMesh's Decimater with ModQuadric and
//    ModNormalFlipping), which keep a subset of the original vertices, so every template vertex
//    lies on the true surface. Then the deformation of Fig. 10, the template's p:
//      1. scaling by `stretch` (per axis) about `center`;
//      2. an ear twist about the vertical (+y, the scan's up axis) line through the "ear_axis"
//         vertex: a vertex at height y turns by ear_twist_deg * clamp((y - y_b) / (y_top - y_b),
//         0, 1), y_b = y_bottom + ear_base * (y_top - y_bottom) over the stretched template's
//         heights (the ears are the top 30% of the bunny); "ear_axis" (a landmark) is the vertex
//         at or below y_b nearest, in x and z, to the centroid of the vertices above y_b; it does
//         not move, so the twist can be undone from the template alone.
//    The correspondence target of template vertex k is its position before the deformation.
#pragma once

#include "experiments/phantoms/phantoms.h"
#include "framework/core/shape.h"

#include <optional>
#include <string>
#include <vector>

namespace dsnake {

// The closed mesh at `path`, scaled uniformly so that its bounding box's longest side is `fit`,
// its bounding-box centre at `center`.
Template<3> load_fitted_mesh(const std::string& path, double fit, const Point<3>& center);

// A mesh file path: required, relative paths resolved against the experiment file's folder
// (the folder of reader.file()), the file must exist. Shared by "mesh" and "bunny".
struct MeshPathKey {
  static void resolve(std::optional<std::string>& path, const JsonReader& reader);
};

// Image phantom "mesh": a closed mesh scaled to `fit`; its default size is fit + 16 per axis.
struct MeshImageOptions {
  CanvasOptions<3> canvas = [] {
    CanvasOptions<3> c;
    c.blur = 0;
    c.size_from_fit = true;
    return c;
  }();
  std::optional<std::string> mesh;
  double fit = 64;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    v(mesh, Key{"mesh", "", "the closed mesh file (OFF/OBJ/PLY/STL), relative to the experiment file's folder (required)"});
    v(fit, Key{"fit", "mm", "the longest side of the scaled mesh's bounding box (default size: fit + 16 voxels per axis)",
               Range::open_closed(0, 4096)});
  }
  void check() const { canvas.check(); }
  void resolve(const JsonReader& reader) { MeshPathKey::resolve(mesh, reader); }  // after the parameters' checks
};

// Image phantom "points": solid balls of `radius` at `centers` (Fig. 1's attracting points).
struct PointsImageOptions {
  CanvasOptions<3> canvas = CanvasOptions<3>::with(GridIndex<3>(64, 64, 64), 0.0);
  double radius = 3;
  std::optional<PointList<3>> centers;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    v(radius, Key{"radius", "mm", "radius of every ball", Range::greater_than(0)});
    v(centers, Key{"centers", "mm", "the balls' centres (required)"});
  }
  void check() const;
};
// The balls' surface: one closed icosphere of 162 vertices per centre, in one surface.
Template<3> points_surface(const PointsImageOptions& options);

struct BunnyDeformation {
  Point<3> stretch = Point<3>(1.1, 0.95, 1.0);
  double ear_twist_deg = 20, ear_base = 0.7;
  template <class V>
  void visit(V& v) {
    v(stretch, Key{"stretch", "1", "scaling per axis about the centre", Range::greater_than(0)});
    v(ear_twist_deg, Key{"ear_twist_deg", "degrees", "the ears' twist at the top about the vertical axis", Range::closed(-180, 180)});
    v(ear_base, Key{"ear_base", "1", "height of the ears' base as a share of the template's height", Range::closed_open(0, 1)});
  }
};

// Template phantom "bunny".
struct BunnyTemplateOptions {
  std::optional<std::string> mesh;
  double fit = 64;
  std::optional<Point<3>> center;  // default: the "mesh" image's centre for this fit
  int vertices = 358;
  BunnyDeformation deformation;
  template <class V>
  void visit(V& v) {
    v(mesh, Key{"mesh", "", "the closed mesh file, as the \"mesh\" image's (required)"});
    v(fit, Key{"fit", "mm", "the longest side of the scaled mesh's bounding box", Range::open_closed(0, 4096)});
    v(center, Key{"center", "mm", "the mesh's bounding-box centre (default: the \"mesh\" image's centre for this fit)"});
    v(vertices, Key{"vertices", "vertices", "about this many vertices after the quadric simplification", Range::closed(8, 1000000)});
    deformation.visit(v);
  }
  void resolve(const JsonReader& reader) { MeshPathKey::resolve(mesh, reader); }
  Point<3> center_point() const;
};

// Applies the deformation to `t` (scaling about `center`, then the ear twist; sets landmark
// "ear_axis"), and its inverse: the undeformed position of every vertex of a deformed template.
void deform_bunny(Template<3>& t, const Point<3>& center, const BunnyDeformation& d);
PointList<3> undeform_bunny(const Template<3>& t, const Point<3>& center, const BunnyDeformation& d);

// Simplifies a closed manifold mesh to about `vertices` vertices by quadric half-edge
// collapses; the result's vertices are a subset of t's (same positions), in their old order.
Template<3> simplify_mesh_quadric(const Template<3>& t, int vertices);

// The template phantom "bunny" and its correspondence targets.
Template<3> make_bunny_template(const BunnyTemplateOptions& options);
std::vector<std::optional<Point<3>>> bunny_targets(const BunnyTemplateOptions& options, const Template<3>& t);

}  // namespace dsnake
