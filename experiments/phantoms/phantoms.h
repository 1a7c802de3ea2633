// Built-in synthetic phantoms with their ground truth, for the default experiment, the tests
// and quick studies. Images follow the paper's star experiment (§8): 8-bit grey levels,
// background 170, foreground 85; binary unless "partial_volume" is true (then boundary voxels
// take the covered fraction), then blurred by "blur" (Gaussian sigma, physical units; 0: none).
//  - image phantoms: "disk", "square", "star" (2D); "sphere", "ellipsoid" (3D);
//  - template phantoms: "circle", "star" (2D); "sphere", "ellipsoid" (3D);
//  - the paper's phantoms (experiments/phantoms/paper_phantoms.h, binary by default: blur 0):
//    image and template "puzzle", "lung_slice" (2D, default images 128^2), "star" (80^3),
//    "tetris", "bone" (64^3), "lung" (230 x 300 x 80, with bronchi) (3D); templates "bar" and
//    "c_shape" (3D). A template's default "center" is the centre of its family's default image.
//  - from a mesh file (experiments/phantoms/bunny.h): image "mesh" (any closed mesh, key "mesh") and
//    "points" (small balls); template "bunny" (the simplified, stretched, ear-twisted bunny).
// Every phantom knows its true boundary (a fine polygon / mesh) and its mask; a template
// phantom of a matching family also gets correspondence targets (see phantom_targets).
// Each family declares its keys once, in an options struct with visit() (units, meanings,
// ranges, defaults), and is registered by name in image_phantoms<D>() or template_phantoms<D>()
// (experiments/phantoms/phantom_registry.h): the experiment reader reads a phantom's section
// into its options, the assembly builds from them, and the schema and docs list their keys.
#pragma once

#include "experiments/phantoms/phantom_registry.h"
#include "framework/core/image.h"
#include "framework/core/options.h"
#include "framework/core/shape.h"

#include <optional>
#include <string>
#include <vector>

namespace dsnake {

template <int D>
struct Phantom {
  std::string kind;
  Image<D> image;        // grey levels
  Image<D> mask;         // 1 inside (voxel centre inside the shape), 0 outside
  Template<D> surface;   // the true boundary, finely sampled
};

// The canvas keys every image phantom takes: the grid, the grey levels, the blur and the
// shape's centre. The paper's phantoms (§8) are binary by default (blur 0), as the paper's
// corruptions expect; the older ones keep a blur of 1.
template <int D>
struct CanvasOptions {
  std::vector<double> size;  // voxels per axis, D integers
  Point<D> spacing = Point<D>::Ones();
  Point<D> origin = Point<D>::Zero();
  double foreground = 85, background = 170, blur = 1.0;
  bool partial_volume = false;  // grey voxels on the boundary (3^D supersampling) or a binary image
  std::optional<Point<D>> center;  // default: the image's centre
  bool size_from_fit = false;  // not a key: the "mesh" phantom's absent size follows its "fit"

  static CanvasOptions with(const GridIndex<D>& size, double blur) {
    CanvasOptions c;
    c.size.assign(size.data(), size.data() + D);
    c.blur = blur;
    return c;
  }
  template <class V>
  void visit(V& v) {
    v(size, Key{"size", "voxels", "voxels per axis, D integers in [4, 4096]"});
    v(spacing, Key{"spacing", "mm", "voxel size per axis", Range::greater_than(0)});
    v(origin, Key{"origin", "mm", "position of the first voxel's centre"});
    v(foreground, Key{"foreground", "grey level", "grey level inside the shape"});
    v(background, Key{"background", "grey level", "grey level outside the shape"});
    v(blur, Key{"blur", "mm", "Gaussian blur sigma applied after rendering (0: none)", Range::at_least(0)});
    v(partial_volume, Key{"partial_volume", "", "boundary voxels take the covered fraction (3^D supersampling) instead of a binary image"});
    v(center, Key{"center", "mm", "the shape's centre (default: the image's centre)"});
  }
  void check() const;
  Grid<D> grid() const;             // size (validated), spacing, origin
  Point<D> center_point() const;    // center, or the grid's centre
};

// Image phantoms "disk" and "square" (2D).
struct DiskOptions {
  CanvasOptions<2> canvas = CanvasOptions<2>::with(GridIndex<2>(128, 128), 1.0);
  double radius = 30;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    v(radius, Key{"radius", "mm", "the disk's radius", Range::greater_than(0)});
  }
  void check() const { canvas.check(); }
};
struct SquareOptions {
  CanvasOptions<2> canvas = CanvasOptions<2>::with(GridIndex<2>(128, 128), 1.0);
  double half_width = 30, rotation_deg = 0;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    v(half_width, Key{"half_width", "mm", "half the square's side", Range::greater_than(0)});
    v(rotation_deg, Key{"rotation_deg", "degrees", "rotation about the centre, counter-clockwise"});
  }
  void check() const { canvas.check(); }
};

// The star shape of the paper's 2D star experiment (§8), shared by the image and the template.
struct StarShape {
  int arms = 5;
  double outer = 40, inner = 18, rotation_deg = 90;
  template <class V>
  void visit(V& v) {
    v(arms, Key{"arms", "", "number of arms", Range::closed(3, 64)});
    v(outer, Key{"outer_radius", "mm", "distance of the arm tips from the centre", Range::greater_than(0)});
    v(inner, Key{"inner_radius", "mm", "distance of the inner vertices from the centre (< outer_radius)", Range::greater_than(0)});
    v(rotation_deg, Key{"rotation_deg", "degrees", "direction of the first arm tip"});
  }
  void check() const {
    if (!(inner < outer)) throw OptionError{"inner_radius", "must be in (0, outer_radius)"};
  }
};
struct StarImageOptions {
  CanvasOptions<2> canvas = CanvasOptions<2>::with(GridIndex<2>(128, 128), 1.0);
  StarShape star;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    star.visit(v);
  }
  void check() const {
    canvas.check();
    star.check();
  }
};

// Image phantoms "sphere" and "ellipsoid" (3D).
struct SphereImageOptions {
  CanvasOptions<3> canvas = CanvasOptions<3>::with(GridIndex<3>(64, 64, 64), 1.0);
  double radius = 20;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    v(radius, Key{"radius", "mm", "the sphere's radius", Range::greater_than(0)});
  }
  void check() const { canvas.check(); }
};
struct EllipsoidImageOptions {
  CanvasOptions<3> canvas = CanvasOptions<3>::with(GridIndex<3>(64, 64, 64), 1.0);
  Point<3> semi_axes = Point<3>(24, 16, 12);
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    v(semi_axes, Key{"semi_axes", "mm", "the ellipsoid's semi-axes along x, y, z", Range::greater_than(0)});
  }
  void check() const { canvas.check(); }
};

// Template phantoms "circle" and "star" (2D), centred by default on their image's centre.
struct CircleTemplateOptions {
  Point<2> center = Point<2>::Constant(63.5);
  double radius = 40;
  int vertices = 40;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the circle's centre"});
    v(radius, Key{"radius", "mm", "the circle's radius", Range::greater_than(0)});
    v(vertices, Key{"vertices", "vertices", "number of vertices, evenly spaced", Range::closed(3, 100000)});
  }
};
struct StarTemplateOptions {
  Point<2> center = Point<2>::Constant(63.5);
  StarShape star;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the star's centre"});
    star.visit(v);
  }
  void check() const { star.check(); }
};

// Template phantoms "sphere" and "ellipsoid" (3D): a scaled icosphere.
struct SphereTemplateOptions {
  Point<3> center = Point<3>::Constant(31.5);
  int subdivisions = 2;
  double radius = 24;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the sphere's centre"});
    v(subdivisions, Key{"subdivisions", "", "icosphere subdivisions: 10 * 4^k + 2 vertices", Range::closed(0, 6)});
    v(radius, Key{"radius", "mm", "the sphere's radius", Range::greater_than(0)});
  }
};
struct EllipsoidTemplateOptions {
  Point<3> center = Point<3>::Constant(31.5);
  int subdivisions = 2;
  Point<3> semi_axes = Point<3>(24, 16, 12);
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the ellipsoid's centre"});
    v(subdivisions, Key{"subdivisions", "", "icosphere subdivisions: 10 * 4^k + 2 vertices", Range::closed(0, 6)});
    v(semi_axes, Key{"semi_axes", "mm", "the ellipsoid's semi-axes along x, y, z", Range::greater_than(0)});
  }
};

// The families that "image": {"phantom": ...} and "template": {"phantom": ...} accept in D
// dimensions. Built on first use.
template <int D>
const PhantomRegistry<Phantom<D>>& image_phantoms();
template <int D>
const PhantomRegistry<Template<D>>& template_phantoms();

// Reads a phantom section (its "phantom" kind and that family's keys) and builds it at once;
// the caller's reader.finish() rejects unknown keys.
template <int D>
Phantom<D> make_phantom(JsonReader& reader);
template <int D>
Template<D> make_template_phantom(JsonReader& reader);

// Correspondence targets for a template phantom registered to an image phantom, where the
// pairing is known: circle/sphere -> disk/sphere/ellipsoid (the template stretched along its
// axes onto the shape), circle -> square (radial projection from the centres, a convention),
// star -> star with the same arm count (vertex k to vertex k); the paper's phantoms to the same
// family (vertex k to the same vertex, barycentric point or arc-length parameter of the true
// shape); the bunny to its undeformed self. Empty otherwise.
template <int D>
std::vector<std::optional<Point<D>>> phantom_targets(const PhantomSpec<Phantom<D>>& image,
                                                     const PhantomSpec<Template<D>>& tmpl,
                                                     const Template<D>& t);

// A closed icosphere of radius 1 about the origin: 10 * 4^k + 2 vertices, outward triangles.
Template<3> make_icosphere(int subdivisions);

}  // namespace dsnake
