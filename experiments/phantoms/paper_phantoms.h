// The shapes of the paper's synthetic experiments (Levi & Gotsman, D-Snake, §6 and §8), as
// exact boundaries with fixed vertex ids, so that a template of the same family has known
// correspondence targets. experiments/phantoms/phantoms.cpp renders them (the voxelised interior of the
// boundary, background 170, foreground 85) and dispatches the phantom names to them:
//  - "star" (3D, Figs. 13-18): the 26 directions of the 3x3x3 neighbourhood, each normalised:
//    ids 0..5 the cube's face centres (+x, -x, +y, -y, +z, -z), the arm tips at outer_radius
//    (landmarks "tip+x", "tip-x", ..., "tip-z");
//    ids 6..17 the 12 edge midpoints and 18..25 the 8 corners at inner_radius. Each cube face
//    carries its 3x3 grid of points as a fan of 8 triangles about its face centre (48
//    triangles, V - E + F = 2): a star with 6 pyramidal arms. A template may be subdivided k
//    times (each triangle 1 -> 4 at its edge midpoints, flat): 26, 98, 386, ... vertices, the
//    first ones keeping their ids.
//  - "tetris" (3D, Fig. 6): the T tetromino, cells [0,3]x[0,1] plus [1,2]x[1,2] (cell units,
//    xy), extruded one cell along z; 10 outline points per cap (the 8 corners and the 2 points
//    splitting the long edge at x = 1, 2), bottom cap ids 0..9, top cap ids 10..19 in the same
//    order; each cap is split into its 4 cells (8 triangles). "center" is the box centre.
//  - "puzzle" (2D, Fig. 2): a square of half_width a with round knobs out on its right (+x) and
//    top (+y) sides and round holes in on its bottom (-y) and left (-x) sides. A knob or hole
//    is the part of a circle of knob_radius, its centre knob_offset outside (knob) or inside
//    (hole) the side's midpoint, that lies beyond the side. The outline runs counter-clockwise
//    from the bottom-left corner through 8 landmarks (corner_bl, hole_bottom, corner_br,
//    knob_right, corner_tr, knob_top, corner_tl, hole_left); the 8 pieces between them have
//    equal length, and a shape's vertices are spread by arc length within each piece.
//  - "bar" / "c_shape" (3D templates, Fig. 8): a square tube along x of `length` and `width`
//    with `rings` rings of 4 vertices and flat end caps; the C is the same mesh (same ids) bent
//    by bend_deg about the z axis, the neutral axis (the tube's centre line) keeping its length
//    and its midpoint at "center".
//  - "lung_slice" (2D, Fig. 4): a smooth lobe, star-shaped about its centre, with one sharp
//    corner: r(t) = R (1 + e cos(2 (t - 90 deg)) + k max(0, 1 - |t - tc| / w)^2), e = elongation,
//    k = corner_height, w = corner_width_deg, tc = corner_deg. r has a kink at tc only (its
//    derivative jumps by 4 k R / w): with the defaults, a corner of about 89 degrees. Vertices are
//    spread by arc length from the corner (vertex 0, landmark "corner").
//  - "lung" (3D, Fig. 9, image 230 x 300 x 80): a lobe about its centre, the point of direction u
//    (unit) at c + rho(u) diag(semi_axes) u, rho(u) = (1 - notch_depth exp(-|u - m|^2 / 0.245))
//    (1 - base_flattening max(0, -u_z)^2), m = (1, 0.3, -0.2) normalised: a cardiac notch on
//    the medial (+x) side and a flatter base (-z). The true surface maps an icosphere (10242
//    vertices); the template a latitude-longitude sphere (rings x segments + 2 poles, default
//    11 x 28 + 2 = 310; "apex" vertex 0 at +z, "base" the last). Inside, a bronchial tree of 11
//    solid tubes (fixed in the lobe's normalised frame, mostly in its upper half, radii
//    bronchus_radius x 1, 0.75, 0.55 by generation) is painted at bronchus_level (default 170,
//    bright as the background): false edges inside the mask. Targets: same direction u.
//  - "bone" (3D, Figs. 11-12, genus 2): a plate of 3 x 5 cubic cells of side `cell` and height
//    `thickness`, cells (1, 1) and (1, 3) left out as two square holes; the 4 x 6 cell corners on
//    the bottom (ids 0..23, x fastest) and top (24..47) faces: 48 vertices, 100 triangles,
//    V - E + F = -2. A template may be subdivided like the star's.
#pragma once

#include "experiments/phantoms/phantoms.h"
#include "framework/core/shape.h"

#include <optional>
#include <string>
#include <vector>

namespace dsnake {

struct Star3dShape {
  double outer = 30, inner = 12;  // radius of the 6 arm tips / of the 20 other vertices
  template <class V>
  void visit(V& v) {
    v(outer, Key{"outer_radius", "mm", "distance of the 6 arm tips from the centre", Range::greater_than(0)});
    v(inner, Key{"inner_radius", "mm", "distance of the 20 other vertices from the centre (< outer_radius)", Range::greater_than(0)});
  }
  void check() const {
    if (!(inner < outer)) throw OptionError{"inner_radius", "must be in (0, outer_radius)"};
  }
};
// The star about `center`, subdivided `subdivisions` times (outward, closed, genus 0).
Template<3> make_star3d(const Point<3>& center, const Star3dShape& star, int subdivisions);

// The T tetromino of cube side `cell` (physical units), its bounding box centred at `center`.
Template<3> make_tetris(const Point<3>& center, double cell);

struct PuzzleShape {
  double half_width = 30, knob_radius = 8, knob_offset = 4;
  template <class V>
  void visit(V& v) {
    v(half_width, Key{"half_width", "mm", "half the square's side", Range::greater_than(0)});
    v(knob_radius, Key{"knob_radius", "mm", "radius of the knobs and holes", Range::greater_than(0)});
    v(knob_offset, Key{"knob_offset", "mm", "distance of a knob's (hole's) circle centre outside (inside) its side, < knob_radius",
                       Range::at_least(0)});
  }
  void check() const;  // knob_offset < knob_radius; the holes stay inside the piece and apart
};
// The puzzle outline with `vertices` vertices (>= 8) about `center`, landmarks named as above.
Template<2> make_puzzle(const Point<2>& center, const PuzzleShape& shape, int vertices);

struct BarShape {
  double length = 48, width = 8;
  int rings = 13;
  template <class V>
  void visit(V& v) {
    v(length, Key{"length", "mm", "length of the tube's centre line", Range::greater_than(0)});
    v(width, Key{"width", "mm", "side of the tube's square cross-section", Range::greater_than(0)});
    v(rings, Key{"rings", "", "rings of 4 vertices along the tube", Range::closed(2, 10000)});
  }
};
// The bar bent by bend_deg (0: straight) about the z axis, centre line through `center`.
Template<3> make_bar(const Point<3>& center, const BarShape& bar, double bend_deg);

struct LungSliceShape {
  double radius = 30, elongation = 0.15, corner_height = 0.4, corner_width_deg = 30, corner_deg = -60;
  template <class V>
  void visit(V& v) {
    v(radius, Key{"radius", "mm", "R, the lobe's mean radius", Range::greater_than(0)});
    v(elongation, Key{"elongation", "1", "e, the lobe's elongation along y", Range::closed(0, 0.5)});
    v(corner_height, Key{"corner_height", "1", "k, the corner's height as a share of R", Range::closed(0, 2)});
    v(corner_width_deg, Key{"corner_width_deg", "degrees", "w, the corner's half-width in polar angle", Range::open_closed(0, 180)});
    v(corner_deg, Key{"corner_deg", "degrees", "tc, the corner's polar angle"});
  }
};
// The lobe with `vertices` vertices spread by arc length from the corner (vertex 0).
Template<2> make_lung_slice(const Point<2>& center, const LungSliceShape& shape, int vertices);

struct LungShape {
  Point<3> semi_axes = Point<3>(80, 120, 32);
  double notch_depth = 0.3, base_flattening = 0.15;
  template <class V>
  void visit(V& v) {
    v(semi_axes, Key{"semi_axes", "mm", "the lobe's semi-axes along x, y, z", Range::greater_than(0)});
    v(notch_depth, Key{"notch_depth", "1", "depth of the cardiac notch on the medial (+x) side", Range::closed(0, 0.6)});
    v(base_flattening, Key{"base_flattening", "1", "flattening of the base (-z)", Range::closed(0, 0.6)});
  }
};
// The lobe over the directions of `unit_sphere` (its positions, normalised; its connectivity).
Template<3> make_lung(const Point<3>& center, const LungShape& shape, const Template<3>& unit_sphere);
// A latitude-longitude unit sphere: pole +z, `rings` rings of `segments`, pole -z; outward.
Template<3> make_latlong_sphere(int rings, int segments);

struct BoneShape {
  double cell = 10, thickness = 10;
  template <class V>
  void visit(V& v) {
    v(cell, Key{"cell", "mm", "side of the plate's square cells", Range::greater_than(0)});
    v(thickness, Key{"thickness", "mm", "the plate's thickness", Range::greater_than(0)});
  }
};
Template<3> make_bone(const Point<3>& center, const BoneShape& bone, int subdivisions);

// A paper image phantom's geometry: its true boundary, plus solid tubes (segment a-b, radius)
// inside it that the renderer paints over the image at tube_level: false edges, not boundary.
template <int D>
struct PaperImageShape {
  struct Tube {
    Point<D> a, b;
    double radius;
  };
  Template<D> surface;
  std::vector<Tube> tubes;
  double tube_level = 170;
};

// The geometry of the image phantoms "puzzle" (its outline sampled every 0.05 mm) and "lung"
// (the surface on an icosphere of 10242 vertices and, unless bronchi is false, its bronchi).
struct LungImageOptions;
PaperImageShape<2> puzzle_image_shape(const Point<2>& center, const PuzzleShape& shape);
PaperImageShape<3> lung_image_shape(const Point<3>& center, const LungImageOptions& options);

// ---- the options of the paper's phantom families (experiments/phantoms/phantoms.h) ----------

struct PuzzleImageOptions {
  CanvasOptions<2> canvas = CanvasOptions<2>::with(GridIndex<2>(128, 128), 0.0);
  PuzzleShape shape;
  template <class V>
  void visit(V& v) { canvas.visit(v); shape.visit(v); }
  void check() const { canvas.check(); shape.check(); }
};
struct PuzzleTemplateOptions {
  Point<2> center = Point<2>::Constant(63.5);
  PuzzleShape shape;
  int vertices = 64;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"});
    shape.visit(v);
    v(vertices, Key{"vertices", "vertices", "number of vertices, spread by arc length between the 8 landmarks", Range::closed(8, 100000)});
  }
  void check() const { shape.check(); }
};
struct LungSliceImageOptions {
  CanvasOptions<2> canvas = CanvasOptions<2>::with(GridIndex<2>(128, 128), 0.0);
  LungSliceShape shape;
  template <class V>
  void visit(V& v) { canvas.visit(v); shape.visit(v); }
  void check() const { canvas.check(); }
};
struct LungSliceTemplateOptions {
  Point<2> center = Point<2>::Constant(63.5);
  LungSliceShape shape;
  int vertices = 32;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"});
    shape.visit(v);
    v(vertices, Key{"vertices", "vertices", "number of vertices, spread by arc length from the corner", Range::closed(3, 100000)});
  }
};
struct Star3dImageOptions {
  CanvasOptions<3> canvas = CanvasOptions<3>::with(GridIndex<3>(80, 80, 80), 0.0);
  Star3dShape star;
  template <class V>
  void visit(V& v) { canvas.visit(v); star.visit(v); }
  void check() const { canvas.check(); star.check(); }
};
struct Star3dTemplateOptions {
  Point<3> center = Point<3>::Constant(39.5);
  Star3dShape star;
  int subdivisions = 0;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"});
    star.visit(v);
    v(subdivisions, Key{"subdivisions", "", "flat subdivisions, each triangle 1 -> 4: 26, 98, 386, ... vertices", Range::closed(0, 5)});
  }
  void check() const { star.check(); }
};
struct TetrisImageOptions {
  CanvasOptions<3> canvas = CanvasOptions<3>::with(GridIndex<3>(64, 64, 64), 0.0);
  double cell = 10;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    v(cell, Key{"cell", "mm", "side of the tetromino's cubic cells", Range::greater_than(0)});
  }
  void check() const { canvas.check(); }
};
struct TetrisTemplateOptions {
  Point<3> center = Point<3>::Constant(31.5);
  double cell = 10;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"});
    v(cell, Key{"cell", "mm", "side of the tetromino's cubic cells", Range::greater_than(0)});
  }
};
struct LungImageOptions {
  CanvasOptions<3> canvas = CanvasOptions<3>::with(GridIndex<3>(230, 300, 80), 0.0);
  LungShape shape;
  bool bronchi = true;
  double bronchus_radius = 2.5, bronchus_level = 170;
  template <class V>
  void visit(V& v) {
    canvas.visit(v);
    shape.visit(v);
    v(bronchi, Key{"bronchi", "", "paint the bronchial tree of 11 tubes inside the lobe (false edges inside the mask)"});
    v(bronchus_radius, Key{"bronchus_radius", "mm", "radius of the main bronchus (x 0.75, 0.55 by generation)", Range::open_closed(0, 10)});
    v(bronchus_level, Key{"bronchus_level", "grey level", "grey level of the bronchi"});
  }
  void check() const { canvas.check(); }
};
struct LungTemplateOptions {
  Point<3> center = Point<3>(114.5, 149.5, 39.5);
  LungShape shape;
  int rings = 11, segments = 28;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"});
    shape.visit(v);
    v(rings, Key{"rings", "", "rings of the latitude-longitude sphere between its poles", Range::closed(1, 1000)});
    v(segments, Key{"segments", "", "vertices per ring", Range::closed(3, 1000)});
  }
};
struct BoneImageOptions {
  CanvasOptions<3> canvas = CanvasOptions<3>::with(GridIndex<3>(64, 64, 64), 0.0);
  BoneShape bone;
  template <class V>
  void visit(V& v) { canvas.visit(v); bone.visit(v); }
  void check() const { canvas.check(); }
};
struct BoneTemplateOptions {
  Point<3> center = Point<3>::Constant(31.5);
  BoneShape bone;
  int subdivisions = 0;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"});
    bone.visit(v);
    v(subdivisions, Key{"subdivisions", "", "flat subdivisions, each triangle 1 -> 4", Range::closed(0, 5)});
  }
};
// "bar" (straight) and "c_shape" (bent by bend_deg about the z axis).
struct BarTemplateOptions {
  Point<3> center = Point<3>::Constant(31.5);
  BarShape bar;
  template <class V>
  void visit(V& v) { v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"}); bar.visit(v); }
};
struct CShapeTemplateOptions {
  Point<3> center = Point<3>::Constant(31.5);
  BarShape bar;
  double bend_deg = 180;
  template <class V>
  void visit(V& v) {
    v(center, Key{"center", "mm", "the shape's centre (default: the centre of its family's default image)"});
    bar.visit(v);
    v(bend_deg, Key{"bend_deg", "degrees", "the bend of the centre line about the z axis (length / bend > width / 2)", Range::closed(0, 300)});
  }
  void check() const;  // the inner side must not fold
};

}  // namespace dsnake
