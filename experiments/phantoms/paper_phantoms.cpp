#include "experiments/phantoms/paper_phantoms.h"

#include "experiments/phantoms/phantoms.h"
#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>

namespace dsnake {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Splits every triangle 1 -> 4 at its edge midpoints (flat, no projection), appending one new
// vertex per edge in the order the edges are first met; existing ids are kept.
void subdivide(PointList<3>& v, std::vector<Triangle>& f) {
  std::map<std::pair<int, int>, int> midpoint;
  auto mid = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    auto it = midpoint.find(key);
    if (it != midpoint.end()) return it->second;
    v.push_back(0.5 * (v[a] + v[b]));
    return midpoint[key] = static_cast<int>(v.size()) - 1;
  };
  std::vector<Triangle> next;
  next.reserve(4 * f.size());
  for (const auto& t : f) {
    const int a = mid(t[0], t[1]), b = mid(t[1], t[2]), c = mid(t[2], t[0]);
    next.insert(next.end(), {Triangle{t[0], a, c}, Triangle{t[1], b, a}, Triangle{t[2], c, b}, Triangle{a, b, c}});
  }
  f.swap(next);
}

Template<3> mesh_template(PointList<3> v, std::vector<Triangle> f) {
  Template<3> t;
  t.connectivity = Connectivity::mesh(static_cast<int>(v.size()), std::move(f));
  t.positions = std::move(v);
  return t;
}

Template<2> polygon_template(PointList<2> p) {
  Template<2> t;
  t.connectivity = Connectivity::polygon(static_cast<int>(p.size()));
  t.positions = std::move(p);
  return t;
}

// ---- 3D star ------------------------------------------------------------------------------

// The 26 neighbourhood directions in id order: face centres (+x, -x, +y, -y, +z, -z), the 12
// edge midpoints (axis pairs xy, xz, yz; signs ++, +-, -+, --), the 8 corners (x slowest).
std::vector<Eigen::Vector3i> star_directions() {
  std::vector<Eigen::Vector3i> d;
  for (int a = 0; a < 3; ++a)
    for (int s : {1, -1}) {
      Eigen::Vector3i e = Eigen::Vector3i::Zero();
      e[a] = s;
      d.push_back(e);
    }
  const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (const auto& p : pairs)
    for (int s0 : {1, -1})
      for (int s1 : {1, -1}) {
        Eigen::Vector3i e = Eigen::Vector3i::Zero();
        e[p[0]] = s0;
        e[p[1]] = s1;
        d.push_back(e);
      }
  for (int x : {1, -1})
    for (int y : {1, -1})
      for (int z : {1, -1}) d.emplace_back(x, y, z);
  return d;
}

}  // namespace

// Figs. 13-18: the 6-armed star; each cube face is a fan of 8 triangles about its arm tip,
// oriented outward (the star is star-shaped about its centre, so a face's outward normal points
// away from the centre).
Template<3> make_star3d(const Point<3>& center, const Star3dShape& star, int subdivisions) {
  DSNAKE_ASSERT(subdivisions >= 0, "subdivisions must be >= 0");
  const auto dirs = star_directions();
  std::map<std::array<int, 3>, int> id;
  PointList<3> v;
  for (size_t k = 0; k < dirs.size(); ++k) {
    id[{dirs[k][0], dirs[k][1], dirs[k][2]}] = static_cast<int>(k);
    v.push_back(center + (k < 6 ? star.outer : star.inner) * dirs[k].cast<double>().normalized());
  }
  const int ring[8][2] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}};
  std::vector<Triangle> f;
  for (int face = 0; face < 6; ++face) {
    const int a = face / 2, s = face % 2 == 0 ? 1 : -1, u = (a + 1) % 3, w = (a + 2) % 3;
    auto at = [&](int i, int j) {
      std::array<int, 3> c{0, 0, 0};
      c[a] = s;
      c[u] = i;
      c[w] = j;
      return id.at(c);
    };
    for (int k = 0; k < 8; ++k) {
      Triangle t{face, at(ring[k][0], ring[k][1]), at(ring[(k + 1) % 8][0], ring[(k + 1) % 8][1])};
      const Point<3> n = (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]);
      if (n.dot(v[t[0]] + v[t[1]] + v[t[2]] - 3 * center) < 0) std::swap(t[1], t[2]);
      f.push_back(t);
    }
  }
  for (int k = 0; k < subdivisions; ++k) subdivide(v, f);
  Template<3> t = mesh_template(std::move(v), std::move(f));
  const char* names[6] = {"tip+x", "tip-x", "tip+y", "tip-y", "tip+z", "tip-z"};
  for (int k = 0; k < 6; ++k) t.landmarks[names[k]] = k;
  return t;
}

// Fig. 6: the T tetromino as an extruded 10-point outline (cell units, counter-clockwise seen
// from +z), caps split into the 4 cells, walls into 2 triangles per outline edge.
Template<3> make_tetris(const Point<3>& center, double cell) {
  const double outline[10][2] = {{0, 0}, {1, 0}, {2, 0}, {3, 0}, {3, 1}, {2, 1}, {2, 2}, {1, 2}, {1, 1}, {0, 1}};
  PointList<3> v;
  for (int z = 0; z < 2; ++z)
    for (const auto& o : outline) v.push_back(center + cell * Point<3>(o[0] - 1.5, o[1] - 1.0, z - 0.5));
  const int cells[4][4] = {{0, 1, 8, 9}, {1, 2, 5, 8}, {2, 3, 4, 5}, {8, 5, 6, 7}};  // CCW from +z
  std::vector<Triangle> f;
  for (const auto& q : cells) {
    f.push_back({q[0], q[2], q[1]});  // bottom cap, facing -z
    f.push_back({q[0], q[3], q[2]});
    f.push_back({q[0] + 10, q[1] + 10, q[2] + 10});  // top cap, facing +z
    f.push_back({q[0] + 10, q[2] + 10, q[3] + 10});
  }
  for (int i = 0; i < 10; ++i) {  // walls: outward on the right of a CCW outline edge
    const int j = (i + 1) % 10;
    f.push_back({i, j, j + 10});
    f.push_back({i, j + 10, i + 10});
  }
  return mesh_template(std::move(v), std::move(f));
}

namespace {

// ---- 2D puzzle piece ------------------------------------------------------------------------

// The point at arc-length fraction u in [0, 1] along side `side` (0 bottom, 1 right, 2 top,
// 3 left; counter-clockwise): straight to the neck, the circle arc of the knob (sigma = +1,
// outward) or hole (sigma = -1, inward), straight to the next corner.
Point<2> puzzle_side_point(const Point<2>& center, const PuzzleShape& p, int side, double u) {
  static const double tangents[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  const Point<2> t(tangents[side][0], tangents[side][1]), n(t.y(), -t.x());  // n: outward
  const double sigma = side == 1 || side == 2 ? 1.0 : -1.0;
  const double a = p.half_width, rho = p.knob_radius, h = p.knob_offset;
  const double w = std::sqrt(rho * rho - h * h);             // half-width of the neck
  const double sweep = 2 * kPi - 2 * std::acos(h / rho);     // the arc beyond the side
  const double straight = a - w, length = 2 * straight + rho * sweep;
  const double l = u * length;
  double s, d;  // along t, along n, from the side's midpoint
  if (l <= straight) {
    s = -a + l, d = 0;
  } else if (l <= straight + rho * sweep) {
    const double phi = std::atan2(-sigma * h, -w) - sigma * (l - straight) / rho;
    s = rho * std::cos(phi), d = sigma * h + rho * std::sin(phi);
  } else {
    s = w + (l - straight - rho * sweep), d = 0;
  }
  return center + (a + d) * n + s * t;
}

// The true puzzle outline: every straight part and arc sampled separately, steps <= max_step,
// so that the corners and the kinks where a knob or hole meets its side are vertices.
PointList<2> puzzle_outline(const Point<2>& center, const PuzzleShape& p, double max_step) {
  const double rho = p.knob_radius, w = std::sqrt(rho * rho - p.knob_offset * p.knob_offset);
  const double straight = p.half_width - w, arc = rho * (2 * kPi - 2 * std::acos(p.knob_offset / rho));
  const double length = 2 * straight + arc, parts[3] = {straight, arc, straight};
  PointList<2> out;
  for (int side = 0; side < 4; ++side) {
    double start = 0;
    for (double part : parts) {
      const int n = std::max(1, int(std::ceil(part / max_step)));
      for (int j = 0; j < n; ++j) out.push_back(puzzle_side_point(center, p, side, (start + part * j / n) / length));
      start += part;
    }
  }
  return out;
}

}  // namespace

// Fig. 2: the puzzle piece; the 8 equal pieces between landmarks get floor((p+1)N/8) -
// floor(pN/8) vertices each, evenly spaced by arc length, so N % 8 == 0 gives a uniform spacing.
Template<2> make_puzzle(const Point<2>& center, const PuzzleShape& shape, int vertices) {
  DSNAKE_ASSERT(vertices >= 8, "a puzzle needs >= 8 vertices");
  const char* names[8] = {"corner_bl", "hole_bottom", "corner_br", "knob_right",
                          "corner_tr", "knob_top",    "corner_tl", "hole_left"};
  PointList<2> pts;
  std::map<std::string, int> landmarks;
  for (int piece = 0; piece < 8; ++piece) {
    const int first = int(int64_t(piece) * vertices / 8), count = int(int64_t(piece + 1) * vertices / 8) - first;
    landmarks[names[piece]] = first;
    for (int j = 0; j < count; ++j)
      pts.push_back(puzzle_side_point(center, shape, piece / 2, 0.5 * (piece % 2) + 0.5 * j / count));
  }
  Template<2> t = polygon_template(std::move(pts));
  t.landmarks = std::move(landmarks);
  return t;
}

// Fig. 8: the square tube, rings of 4 (y, z) corners; for bend_deg > 0 the point (x, y, z) goes
// to the circle of radius R - y about (0, R) at angle x / R, R = length / bend (the centre line
// keeps its length).
Template<3> make_bar(const Point<3>& center, const BarShape& bar, double bend_deg) {
  DSNAKE_ASSERT(bar.rings >= 2, "a bar needs >= 2 rings");
  const double bend = bend_deg * kPi / 180.0, radius = bend > 0 ? bar.length / bend : 0.0;
  const double corners[4][2] = {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
  PointList<3> v;
  for (int i = 0; i < bar.rings; ++i) {
    const double x = -0.5 * bar.length + bar.length * i / (bar.rings - 1);
    for (const auto& c : corners) {
      const double y = c[0] * bar.width, z = c[1] * bar.width;
      if (bend > 0) {
        const double phi = x / radius;
        v.push_back(center + Point<3>((radius - y) * std::sin(phi), radius - (radius - y) * std::cos(phi), z));
      } else {
        v.push_back(center + Point<3>(x, y, z));
      }
    }
  }
  std::vector<Triangle> f;
  for (int i = 0; i + 1 < bar.rings; ++i)
    for (int j = 0; j < 4; ++j) {
      const int a = 4 * i + j, b = 4 * i + (j + 1) % 4, c = b + 4, d = a + 4;
      f.push_back({a, b, c});
      f.push_back({a, c, d});
    }
  const int last = 4 * (bar.rings - 1);
  f.push_back({0, 2, 1});
  f.push_back({0, 3, 2});
  f.push_back({last, last + 1, last + 2});
  f.push_back({last, last + 2, last + 3});
  if (signed_measure<3>(v, Connectivity::mesh(int(v.size()), f)) < 0)
    for (auto& t : f) std::swap(t[1], t[2]);
  Template<3> t = mesh_template(std::move(v), std::move(f));
  t.landmarks["end0"] = 0;
  t.landmarks["end1"] = last;
  return t;
}

namespace {

// ---- 2D lung-like slice ---------------------------------------------------------------------

// The lobe's radius at polar angle t (radians), in units of R.
double lung_radius(const LungSliceShape& s, double t) {
  const double tc = s.corner_deg * kPi / 180.0, w = s.corner_width_deg * kPi / 180.0;
  const double delta = std::remainder(t - tc, 2 * kPi);
  const double bump = std::max(0.0, 1.0 - std::abs(delta) / w);
  return 1.0 + s.elongation * std::cos(2 * (t - 0.5 * kPi)) + s.corner_height * bump * bump;
}

}  // namespace

// Fig. 4: angles with equal arc length from the corner, through a table of 2^15 chords of the
// exact curve (the table is scale-free, so template and image share the parameterisation).
Template<2> make_lung_slice(const Point<2>& center, const LungSliceShape& shape, int vertices) {
  DSNAKE_ASSERT(vertices >= 3, "a lung slice needs >= 3 vertices");
  constexpr int kSteps = 1 << 15;
  const double tc = shape.corner_deg * kPi / 180.0;
  auto point = [&](double t) -> Point<2> { return Point<2>(std::cos(t), std::sin(t)) * lung_radius(shape, t); };
  std::vector<double> cumulative(kSteps + 1, 0.0);
  for (int i = 0; i < kSteps; ++i)
    cumulative[i + 1] = cumulative[i] + (point(tc + 2 * kPi * (i + 1) / kSteps) - point(tc + 2 * kPi * i / kSteps)).norm();
  PointList<2> pts;
  for (int k = 0; k < vertices; ++k) {
    const double l = cumulative.back() * k / vertices;
    const int i = int(std::upper_bound(cumulative.begin(), cumulative.end(), l) - cumulative.begin()) - 1;
    const double f = (l - cumulative[i]) / (cumulative[i + 1] - cumulative[i]);
    pts.push_back(center + shape.radius * point(tc + 2 * kPi * (i + f) / kSteps));
  }
  Template<2> t = polygon_template(std::move(pts));
  t.landmarks["corner"] = 0;
  return t;
}

// ---- 3D lung-like volume and genus-2 bone -----------------------------------------------------

namespace {

// rho(u) of the lobe (header), u a unit direction.
double lung_rho(const LungShape& s, const Point<3>& u) {
  const Point<3> notch = Point<3>(1, 0.3, -0.2).normalized();
  const double below = std::max(0.0, -u.z());
  return (1 - s.notch_depth * std::exp(-(u - notch).squaredNorm() / (2 * 0.35 * 0.35))) *
         (1 - s.base_flattening * below * below);
}

// The bronchial tree in the lobe's normalised frame (unit ball scaled by the semi-axes):
// main bronchus, 4 lobar branches, 6 segmental ones; generation 0, 1, 2.
struct NormalisedTube {
  double a[3], b[3];
  int generation;
};
constexpr NormalisedTube kBronchi[] = {
    {{0.30, 0.00, 0.70}, {0.30, 0.00, 0.20}, 0},     {{0.30, 0.00, 0.20}, {0.05, 0.45, 0.55}, 1},
    {{0.30, 0.00, 0.20}, {0.05, -0.45, 0.55}, 1},    {{0.30, 0.00, 0.20}, {0.05, 0.35, -0.35}, 1},
    {{0.30, 0.00, 0.20}, {0.10, -0.40, -0.30}, 1},   {{0.05, 0.45, 0.55}, {-0.30, 0.55, 0.60}, 2},
    {{0.05, 0.45, 0.55}, {-0.20, 0.75, 0.30}, 2},    {{0.05, -0.45, 0.55}, {-0.30, -0.55, 0.60}, 2},
    {{0.05, -0.45, 0.55}, {-0.20, -0.75, 0.30}, 2},  {{0.05, 0.35, -0.35}, {-0.25, 0.50, -0.45}, 2},
    {{0.10, -0.40, -0.30}, {-0.25, -0.55, -0.40}, 2}};

}  // namespace

// Fig. 9: every direction of the unit sphere pushed to the lobe's boundary.
Template<3> make_lung(const Point<3>& center, const LungShape& shape, const Template<3>& unit_sphere) {
  Template<3> t = unit_sphere;
  for (auto& p : t.positions) {
    const Point<3> u = p.normalized();
    p = center + lung_rho(shape, u) * shape.semi_axes.cwiseProduct(u);
  }
  return t;
}

// Ring k (1..rings) at polar angle pi k / (rings + 1), vertex j at azimuth 2 pi j / segments;
// caps are fans about the poles, bands quads split in two.
Template<3> make_latlong_sphere(int rings, int segments) {
  DSNAKE_ASSERT(rings >= 1 && segments >= 3, "a sphere needs >= 1 ring of >= 3 vertices");
  PointList<3> v{Point<3>(0, 0, 1)};
  for (int k = 1; k <= rings; ++k)
    for (int j = 0; j < segments; ++j) {
      const double theta = kPi * k / (rings + 1), phi = 2 * kPi * j / segments;
      v.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    }
  v.emplace_back(0, 0, -1);
  const int south = static_cast<int>(v.size()) - 1;
  auto at = [&](int k, int j) { return 1 + (k - 1) * segments + (j % segments); };
  std::vector<Triangle> f;
  for (int j = 0; j < segments; ++j) {
    f.push_back({0, at(1, j), at(1, j + 1)});
    for (int k = 1; k < rings; ++k) {
      f.push_back({at(k, j), at(k + 1, j), at(k + 1, j + 1)});
      f.push_back({at(k, j), at(k + 1, j + 1), at(k, j + 1)});
    }
    f.push_back({south, at(rings, j + 1), at(rings, j)});
  }
  Template<3> t = mesh_template(std::move(v), std::move(f));
  t.landmarks["apex"] = 0;
  t.landmarks["base"] = south;
  return t;
}

// Figs. 11-12: the two-holed plate; caps split cell by cell, a wall on every cell edge between
// a solid cell and a hole or the outside (outward on the right of the cell's CCW boundary).
Template<3> make_bone(const Point<3>& center, const BoneShape& bone, int subdivisions) {
  constexpr int nx = 3, ny = 5, layer = (nx + 1) * (ny + 1);
  auto solid = [](int i, int j) { return i >= 0 && i < nx && j >= 0 && j < ny && !(i == 1 && (j == 1 || j == 3)); };
  auto id = [](int i, int j, int z) { return z * (nx + 1) * (ny + 1) + j * (nx + 1) + i; };
  PointList<3> v;
  for (int z = 0; z < 2; ++z)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i)
        v.push_back(center + Point<3>(bone.cell * (i - 0.5 * nx), bone.cell * (j - 0.5 * ny), bone.thickness * (z - 0.5)));
  std::vector<Triangle> f;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      if (!solid(i, j)) continue;
      const int q[4][2] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};  // CCW from +z
      const int b[4] = {id(q[0][0], q[0][1], 0), id(q[1][0], q[1][1], 0), id(q[2][0], q[2][1], 0), id(q[3][0], q[3][1], 0)};
      const int t[4] = {b[0] + layer, b[1] + layer, b[2] + layer, b[3] + layer};
      f.insert(f.end(), {Triangle{b[0], b[2], b[1]}, Triangle{b[0], b[3], b[2]}, Triangle{t[0], t[1], t[2]},
                         Triangle{t[0], t[2], t[3]}});
      const int neighbour[4][2] = {{i, j - 1}, {i + 1, j}, {i, j + 1}, {i - 1, j}};  // across edge e -> e+1
      for (int e = 0; e < 4; ++e)
        if (!solid(neighbour[e][0], neighbour[e][1])) {
          const int a = b[e], c = b[(e + 1) % 4];
          f.insert(f.end(), {Triangle{a, c, c + layer}, Triangle{a, c + layer, a + layer}});
        }
    }
  for (int k = 0; k < subdivisions; ++k) subdivide(v, f);
  return mesh_template(std::move(v), std::move(f));
}

// ---- the options' cross-key rules and the image shapes -----------------------------------------

void PuzzleShape::check() const {
  if (!(knob_offset < knob_radius)) throw OptionError{"knob_offset", "must be in [0, knob_radius)"};
  if (!(knob_radius + knob_offset < half_width))
    throw OptionError{"knob_radius", "knob_radius + knob_offset must be < half_width (a hole would cut through the piece)"};
  if (!(std::sqrt(2.0) * (half_width - knob_offset) > 2 * knob_radius))
    throw OptionError{"knob_radius", "too large: the two holes would overlap"};
}

void CShapeTemplateOptions::check() const {
  if (!(bend_deg == 0 || bar.length / (bend_deg * kPi / 180.0) > 0.5 * bar.width))
    throw OptionError{"bend_deg", "too large for the bar: the inner side would fold (need length / bend > width / 2)"};
}

PaperImageShape<2> puzzle_image_shape(const Point<2>& center, const PuzzleShape& shape) {
  PaperImageShape<2> s;
  s.surface = polygon_template(puzzle_outline(center, shape, 0.05));
  return s;
}

// The true lung surface and its bronchi.
PaperImageShape<3> lung_image_shape(const Point<3>& center, const LungImageOptions& o) {
  PaperImageShape<3> out;
  out.tube_level = o.bronchus_level;
  out.surface = make_lung(center, o.shape, make_icosphere(5));
  const double scale[3] = {1.0, 0.75, 0.55};
  if (o.bronchi)
    for (const auto& t : kBronchi)
      out.tubes.push_back({center + o.shape.semi_axes.cwiseProduct(Point<3>(t.a[0], t.a[1], t.a[2])),
                           center + o.shape.semi_axes.cwiseProduct(Point<3>(t.b[0], t.b[1], t.b[2])),
                           o.bronchus_radius * scale[t.generation]});
  return out;
}

}  // namespace dsnake
