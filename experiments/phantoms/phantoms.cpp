#include "experiments/phantoms/phantoms.h"

#include "experiments/phantoms/bunny.h"
#include "experiments/phantoms/paper_phantoms.h"
#include "framework/core/errors.h"
#include "framework/core/image_filters.h"
#include "framework/metrics/metrics.h"

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>

namespace dsnake {

namespace {

constexpr double kPi = 3.14159265358979323846;

// The geometry shared by image phantoms: grid, grey levels, blur.
template <int D>
struct PhantomCanvas {
  Grid<D> grid;
  double foreground = 85, background = 170, blur = 1.0;
  bool partial_volume = false;  // grey voxels on the boundary (3^D supersampling) or a binary image
  Point<D> center;
};

template <int D>
PhantomCanvas<D> canvas_of(const CanvasOptions<D>& o) {
  PhantomCanvas<D> c;
  c.grid = o.grid();
  c.foreground = o.foreground;
  c.background = o.background;
  c.blur = o.blur;
  c.partial_volume = o.partial_volume;
  c.center = o.center ? *o.center : c.grid.origin + 0.5 * (c.grid.size.template cast<double>() - Point<D>::Ones()).cwiseProduct(c.grid.spacing);
  return c;
}

// Star polygon: outer vertices at rotation + 2 pi k / arms, inner ones half-way (2 * arms).
PointList<2> star_polygon(const Point<2>& c, const StarShape& star) {
  PointList<2> p;
  const double rot = star.rotation_deg * kPi / 180.0;
  for (int k = 0; k < 2 * star.arms; ++k) {
    const double a = rot + kPi * k / star.arms;
    const double r = k % 2 == 0 ? star.outer : star.inner;
    p.push_back(c + r * Point<2>(std::cos(a), std::sin(a)));
  }
  return p;
}

bool inside_polygon(const PointList<2>& poly, const Point<2>& x) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const auto& a = poly[i];
    const auto& b = poly[j];
    if ((a.y() > x.y()) != (b.y() > x.y()) &&
        x.x() < (b.x() - a.x()) * (x.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

// Renders the image (binary, or partial-volume by 3^D supersampling; then the blur) and the mask.
template <int D>
void render(Phantom<D>& ph, const PhantomCanvas<D>& c, const std::function<bool(const Point<D>&)>& inside) {
  ph.image = Image<D>(c.grid);
  ph.mask = Image<D>(c.grid);
  const int64_t n = c.grid.num_voxels();
  const int sub = c.partial_volume ? 3 : 1;
  const int samples = D == 2 ? sub * sub : sub * sub * sub;
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    const Point<D> x = c.grid.to_physical(c.grid.index(l));
    int count = 0;
    for (int s = 0; s < samples; ++s) {
      Point<D> y = x;
      int rest = s;
      for (int a = 0; a < D; ++a) {
        y[a] += ((rest % sub) - (sub - 1) / 2.0) / double(sub) * c.grid.spacing[a];
        rest /= sub;
      }
      count += inside(y);
    }
    const double frac = double(count) / samples;
    ph.image[l] = static_cast<float>(c.background + frac * (c.foreground - c.background));
    ph.mask[l] = inside(x) ? 1.0f : 0.0f;
  }
  ph.image = gaussian_blur(std::move(ph.image), c.blur);
}

// Paints a solid tube (the points within `radius` of segment a-b) at grey level `level` over
// the image: the covered fraction of each voxel (3^D sub-voxel centres) with partial volume,
// else the voxels whose centre it covers. Tubes are painted one after the other, so overlapping
// ones give the same image for any thread count.
template <int D>
void paint_tube(Image<D>& image, const PhantomCanvas<D>& c, const typename PaperImageShape<D>::Tube& tube, double level) {
  const Grid<D>& g = c.grid;
  GridIndex<D> lo, extent;
  for (int a = 0; a < D; ++a) {
    const double x0 = std::min(tube.a[a], tube.b[a]) - tube.radius, x1 = std::max(tube.a[a], tube.b[a]) + tube.radius;
    lo[a] = std::max(0, int(std::floor((x0 - g.origin[a]) / g.spacing[a])));
    extent[a] = std::min(g.size[a] - 1, int(std::ceil((x1 - g.origin[a]) / g.spacing[a]))) - lo[a] + 1;
    if (extent[a] <= 0) return;
  }
  const Point<D> axis = tube.b - tube.a;
  const double len2 = axis.squaredNorm();
  auto covered = [&](const Point<D>& x) {
    const double t = len2 > 0 ? std::clamp((x - tube.a).dot(axis) / len2, 0.0, 1.0) : 0.0;
    return (x - tube.a - t * axis).squaredNorm() < tube.radius * tube.radius;
  };
  const int sub = c.partial_volume ? 3 : 1, samples = D == 2 ? sub * sub : sub * sub * sub;
  const int64_t n = extent.template cast<int64_t>().prod();
#pragma omp parallel for schedule(static)
  for (int64_t l = 0; l < n; ++l) {
    GridIndex<D> i;
    int64_t rest = l;
    for (int a = 0; a < D; ++a) {
      i[a] = lo[a] + int(rest % extent[a]);
      rest /= extent[a];
    }
    const Point<D> x = g.to_physical(i);
    int count = 0;
    for (int s = 0; s < samples; ++s) {
      Point<D> y = x;
      int r = s;
      for (int a = 0; a < D; ++a, r /= sub) y[a] += ((r % sub) - (sub - 1) / 2.0) / double(sub) * g.spacing[a];
      count += covered(y);
    }
    float& v = image.at(i);
    v = static_cast<float>(v + double(count) / samples * (level - v));
  }
}

// Renders the interior of a closed boundary (polygon or mesh) as render() does, with the
// rasteriser of the metrics (framework/metrics/metrics.h), so that the mask is exactly the Dice mask of
// the true surface; partial volume counts the 3^D sub-voxel centres on a grid 3 times finer.
template <int D>
void render_surface(Phantom<D>& ph, const PhantomCanvas<D>& c, const PaperImageShape<D>& shape) {
  ph.surface = shape.surface;
  const SurfaceRef<D> surface{ph.surface.positions, ph.surface.connectivity};
  ph.mask = rasterize_interior<D>(surface, c.grid);
  ph.image = Image<D>(c.grid);
  const int64_t n = c.grid.num_voxels();
  if (!c.partial_volume) {
    for (int64_t l = 0; l < n; ++l)
      ph.image[l] = static_cast<float>(ph.mask[l] != 0 ? c.foreground : c.background);
  } else {
    // One layer of voxels (along the last axis) at a time: the 3x finer grid of a whole volume
    // would take 27 times the image's memory.
    constexpr int sub = 3, last = D - 1;
    const int samples = D == 2 ? sub * sub : sub * sub * sub;
    const int64_t per_layer = n / c.grid.size[last];
    for (int k = 0; k < c.grid.size[last]; ++k) {
      Grid<D> fine = c.grid;
      fine.size = c.grid.size * sub;
      fine.size[last] = sub;
      fine.spacing = c.grid.spacing / sub;
      fine.origin = c.grid.origin - fine.spacing;  // sub-voxel centres at -1/3, 0, +1/3 voxel
      fine.origin[last] += k * c.grid.spacing[last];
      const Image<D> inside = rasterize_interior<D>(surface, fine);
#pragma omp parallel for schedule(static)
      for (int64_t m = 0; m < per_layer; ++m) {
        const int64_t l = k * per_layer + m;
        GridIndex<D> i = c.grid.index(l);
        i[last] = 0;
        int count = 0;
        for (int s = 0; s < samples; ++s) {
          GridIndex<D> f = sub * i;
          int rest = s;
          for (int a = 0; a < D; ++a, rest /= sub) f[a] += rest % sub;
          count += inside.at(f) != 0;
        }
        ph.image[l] = static_cast<float>(c.background + double(count) / samples * (c.foreground - c.background));
      }
    }
  }
  for (const auto& tube : shape.tubes) paint_tube(ph.image, c, tube, shape.tube_level);
  ph.image = gaussian_blur(std::move(ph.image), c.blur);
}

Template<2> polygon_template(PointList<2> p) {
  Template<2> t;
  t.connectivity = Connectivity::polygon(static_cast<int>(p.size()));
  t.positions = std::move(p);
  return t;
}

PointList<2> circle_points(const Point<2>& c, double r, int n) {
  PointList<2> p;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * kPi * k / n;
    p.push_back(c + r * Point<2>(std::cos(a), std::sin(a)));
  }
  return p;
}

Template<3> scaled_icosphere(int subdivisions, const Point<3>& center, const Point<3>& axes) {
  Template<3> t = make_icosphere(subdivisions);
  for (auto& p : t.positions) p = center + p.cwiseProduct(axes);
  return t;
}

}  // namespace

Template<3> make_icosphere(int subdivisions) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  PointList<3> v = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                    {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  std::vector<Triangle> f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
                             {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                             {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
                             {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (auto& p : v) p.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return midpoint[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<Triangle> next;
    for (const auto& t : f) {
      const int a = mid(t[0], t[1]), b = mid(t[1], t[2]), c = mid(t[2], t[0]);
      next.insert(next.end(), {Triangle{t[0], a, c}, Triangle{t[1], b, a}, Triangle{t[2], c, b}, Triangle{a, b, c}});
    }
    f.swap(next);
  }
  Template<3> t;
  t.connectivity = Connectivity::mesh(static_cast<int>(v.size()), std::move(f));
  t.positions = std::move(v);
  return t;
}

template <int D>
void CanvasOptions<D>::check() const {
  if (size.empty() && size_from_fit) return;
  if (int(size.size()) != D) throw OptionError{"size", "expected " + std::to_string(D) + " integers"};
  for (double n : size)
    if (!(n >= 4 && n <= 4096 && n == std::floor(n))) throw OptionError{"size", "each size must be an integer in [4, 4096]"};
}

template <int D>
Grid<D> CanvasOptions<D>::grid() const {
  DSNAKE_ASSERT(int(size.size()) == D, "a canvas with its size");
  Grid<D> g;
  for (int a = 0; a < D; ++a) g.size[a] = static_cast<int>(size[a]);
  g.spacing = spacing;
  g.origin = origin;
  return g;
}

template <int D>
Point<D> CanvasOptions<D>::center_point() const {
  return canvas_of(*this).center;
}

template struct CanvasOptions<2>;
template struct CanvasOptions<3>;

namespace {

// An image phantom rendered from an inside test (render) or from its exact boundary
// (render_surface).
template <int D>
Phantom<D> inside_phantom(const char* kind, const CanvasOptions<D>& o, const std::function<bool(const Point<D>&)>& inside) {
  Phantom<D> ph;
  ph.kind = kind;
  render<D>(ph, canvas_of(o), inside);
  return ph;
}
template <int D>
Phantom<D> boundary_phantom(const char* kind, const CanvasOptions<D>& o, const PaperImageShape<D>& shape) {
  Phantom<D> ph;
  ph.kind = kind;
  render_surface<D>(ph, canvas_of(o), shape);
  return ph;
}
template <int D>
PaperImageShape<D> boundary_only(Template<D> surface) {
  PaperImageShape<D> s;
  s.surface = std::move(surface);
  return s;
}

Phantom<2> square_phantom(const SquareOptions& o) {
  const Point<2> center = o.canvas.center_point();
  const double half = o.half_width;
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(o.rotation_deg * kPi / 180.0).toRotationMatrix();
  Phantom<2> ph = inside_phantom<2>("square", o.canvas, [&](const Point<2>& x) {
    const Point<2> y = R.transpose() * (x - center);
    return std::max(std::abs(y.x()), std::abs(y.y())) < half;
  });
  PointList<2> p;
  const Point<2> corners[4] = {{half, -half}, {half, half}, {-half, half}, {-half, -half}};
  constexpr int kPerSide = 128;
  for (int s = 0; s < 4; ++s)
    for (int k = 0; k < kPerSide; ++k) {
      const double t = double(k) / kPerSide;
      p.push_back(center + R * ((1 - t) * corners[s] + t * corners[(s + 1) % 4]));
    }
  ph.surface = polygon_template(std::move(p));
  return ph;
}

template <class Options>
Phantom<3> ellipsoid_phantom(const char* kind, const Options& o, const Point<3>& axes) {
  const Point<3> center = o.canvas.center_point();
  Phantom<3> ph = inside_phantom<3>(kind, o.canvas, [&](const Point<3>& x) {
    return (x - center).cwiseQuotient(axes).squaredNorm() < 1.0;
  });
  ph.surface = scaled_icosphere(5, center, axes);
  return ph;
}

// The six axis extremes of a 3D template, as landmarks "+x", "-x", ..., "-z".
void add_axis_landmarks(Template<3>& t) {
  const char* names[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};
  for (int k = 0; k < 6; ++k) {
    int best = 0;
    const double sign = k % 2 == 0 ? 1.0 : -1.0;
    for (int v = 1; v < t.num_vertices(); ++v)
      if (sign * (t.positions[v][k / 2] - t.positions[best][k / 2]) > 0) best = v;
    t.landmarks[names[k]] = best;
  }
}

Template<3> icosphere_template(const Point<3>& center, int subdivisions, const Point<3>& axes) {
  Template<3> t = scaled_icosphere(subdivisions, center, axes);
  add_axis_landmarks(t);
  return t;
}

Phantom<3> mesh_phantom(const MeshImageOptions& o) {
  CanvasOptions<3> canvas = o.canvas;
  if (canvas.size.empty()) canvas.size.assign(3, std::ceil(o.fit) + 16);
  return boundary_phantom<3>("mesh", canvas, boundary_only<3>(load_fitted_mesh(*o.mesh, o.fit, canvas.center_point())));
}

void add_image_phantoms(PhantomRegistry<Phantom<2>>& r) {
  r.add<DiskOptions>("disk", "a disk of `radius`", [](const DiskOptions& o) {
    const Point<2> center = o.canvas.center_point();
    Phantom<2> ph = inside_phantom<2>("disk", o.canvas, [&](const Point<2>& x) { return (x - center).norm() < o.radius; });
    ph.surface = polygon_template(circle_points(center, o.radius, 1024));
    return ph;
  });
  r.add<SquareOptions>("square", "a square of side 2 half_width, rotated by rotation_deg", square_phantom);
  r.add<StarImageOptions>("star", "the star of the paper's 2D experiments (§8)", [](const StarImageOptions& o) {
    const PointList<2> poly = star_polygon(o.canvas.center_point(), o.star);
    Phantom<2> ph = inside_phantom<2>("star", o.canvas, [&](const Point<2>& x) { return inside_polygon(poly, x); });
    ph.surface = polygon_template(poly);
    return ph;
  });
  r.add<PuzzleImageOptions>("puzzle", "the puzzle piece of Fig. 2", [](const PuzzleImageOptions& o) {
    return boundary_phantom<2>("puzzle", o.canvas, puzzle_image_shape(o.canvas.center_point(), o.shape));
  });
  r.add<LungSliceImageOptions>("lung_slice", "the lung slice of Fig. 4: a smooth lobe with one sharp corner",
                               [](const LungSliceImageOptions& o) {
                                 return boundary_phantom<2>("lung_slice", o.canvas,
                                                            boundary_only<2>(make_lung_slice(o.canvas.center_point(), o.shape, 4096)));
                               });
}

void add_image_phantoms(PhantomRegistry<Phantom<3>>& r) {
  r.add<SphereImageOptions>("sphere", "a ball of `radius`", [](const SphereImageOptions& o) {
    return ellipsoid_phantom("sphere", o, Point<3>::Constant(o.radius));
  });
  r.add<EllipsoidImageOptions>("ellipsoid", "an axis-aligned ellipsoid", [](const EllipsoidImageOptions& o) {
    return ellipsoid_phantom("ellipsoid", o, o.semi_axes);
  });
  r.add<Star3dImageOptions>("star", "the 6-armed star of Figs. 13-18", [](const Star3dImageOptions& o) {
    return boundary_phantom<3>("star", o.canvas, boundary_only<3>(make_star3d(o.canvas.center_point(), o.star, 0)));
  });
  r.add<TetrisImageOptions>("tetris", "the T tetromino of Fig. 6", [](const TetrisImageOptions& o) {
    return boundary_phantom<3>("tetris", o.canvas, boundary_only<3>(make_tetris(o.canvas.center_point(), o.cell)));
  });
  r.add<LungImageOptions>("lung", "the lung-like lobe of Fig. 9, with a bronchial tree", [](const LungImageOptions& o) {
    return boundary_phantom<3>("lung", o.canvas, lung_image_shape(o.canvas.center_point(), o));
  });
  r.add<BoneImageOptions>("bone", "the genus-2 plate of Figs. 11-12", [](const BoneImageOptions& o) {
    return boundary_phantom<3>("bone", o.canvas, boundary_only<3>(make_bone(o.canvas.center_point(), o.bone, 0)));
  });
  r.add<MeshImageOptions>("mesh", "a closed mesh file, scaled to `fit` (experiments/phantoms/bunny.h)", mesh_phantom);
  r.add<PointsImageOptions>("points", "small solid balls: Fig. 1's attracting points", [](const PointsImageOptions& o) {
    return boundary_phantom<3>("points", o.canvas, boundary_only<3>(points_surface(o)));
  });
}

void add_template_phantoms(PhantomRegistry<Template<2>>& r) {
  r.add<CircleTemplateOptions>("circle", "a circle of evenly spaced vertices", [](const CircleTemplateOptions& o) {
    return polygon_template(circle_points(o.center, o.radius, o.vertices));
  });
  r.add<StarTemplateOptions>("star", "the star polygon (2 arms vertices, landmarks tip0, tip1, ...)", [](const StarTemplateOptions& o) {
    Template<2> t = polygon_template(star_polygon(o.center, o.star));
    for (int k = 0; k < o.star.arms; ++k) t.landmarks["tip" + std::to_string(k)] = 2 * k;
    return t;
  });
  r.add<PuzzleTemplateOptions>("puzzle", "the puzzle piece of Fig. 2, with its 8 landmarks", [](const PuzzleTemplateOptions& o) {
    return make_puzzle(o.center, o.shape, o.vertices);
  });
  r.add<LungSliceTemplateOptions>("lung_slice", "the lung slice of Fig. 4 (landmark \"corner\": vertex 0)",
                                  [](const LungSliceTemplateOptions& o) { return make_lung_slice(o.center, o.shape, o.vertices); });
}

void add_template_phantoms(PhantomRegistry<Template<3>>& r) {
  r.add<SphereTemplateOptions>("sphere", "an icosphere, with the six axis extremes as landmarks", [](const SphereTemplateOptions& o) {
    return icosphere_template(o.center, o.subdivisions, Point<3>::Constant(o.radius));
  });
  r.add<EllipsoidTemplateOptions>("ellipsoid", "an icosphere scaled to the semi-axes, with the six axis extremes as landmarks",
                                  [](const EllipsoidTemplateOptions& o) { return icosphere_template(o.center, o.subdivisions, o.semi_axes); });
  r.add<Star3dTemplateOptions>("star", "the 6-armed star of Figs. 13-18", [](const Star3dTemplateOptions& o) {
    return make_star3d(o.center, o.star, o.subdivisions);
  });
  r.add<TetrisTemplateOptions>("tetris", "the T tetromino of Fig. 6", [](const TetrisTemplateOptions& o) { return make_tetris(o.center, o.cell); });
  r.add<BarTemplateOptions>("bar", "the straight square tube of Fig. 8", [](const BarTemplateOptions& o) { return make_bar(o.center, o.bar, 0); });
  r.add<CShapeTemplateOptions>("c_shape", "the square tube of Fig. 8 bent into a C", [](const CShapeTemplateOptions& o) {
    return make_bar(o.center, o.bar, o.bend_deg);
  });
  r.add<LungTemplateOptions>("lung", "the lobe of Fig. 9 on a latitude-longitude sphere", [](const LungTemplateOptions& o) {
    return make_lung(o.center, o.shape, make_latlong_sphere(o.rings, o.segments));
  });
  r.add<BoneTemplateOptions>("bone", "the genus-2 plate of Figs. 11-12", [](const BoneTemplateOptions& o) {
    return make_bone(o.center, o.bone, o.subdivisions);
  });
  r.add<BunnyTemplateOptions>("bunny", "the simplified, stretched, ear-twisted bunny of Fig. 10 (experiments/phantoms/bunny.h)",
                              make_bunny_template);
}

}  // namespace

template <int D>
const PhantomRegistry<Phantom<D>>& image_phantoms() {
  static const PhantomRegistry<Phantom<D>> registry = [] {
    PhantomRegistry<Phantom<D>> r(std::to_string(D) + "D image");
    add_image_phantoms(r);
    return r;
  }();
  return registry;
}

template <int D>
const PhantomRegistry<Template<D>>& template_phantoms() {
  static const PhantomRegistry<Template<D>> registry = [] {
    PhantomRegistry<Template<D>> r(std::to_string(D) + "D template");
    add_template_phantoms(r);
    return r;
  }();
  return registry;
}

template <int D>
Phantom<D> make_phantom(JsonReader& reader) {
  return image_phantoms<D>().read(reader).build();
}

template <int D>
Template<D> make_template_phantom(JsonReader& reader) {
  return template_phantoms<D>().read(reader).build();
}

namespace {

// The template's direction from its centre in its own ellipsoid frame, mapped onto the image's
// ellipsoid.
template <int D>
std::vector<std::optional<Point<D>>> radial_targets(const Template<D>& t, const Point<D>& template_center,
                                                    const Point<D>& template_axes, const Point<D>& image_center,
                                                    const Point<D>& image_axes) {
  std::vector<std::optional<Point<D>>> targets;
  for (const auto& p : t.positions)
    targets.emplace_back(image_center + (p - template_center).cwiseQuotient(template_axes).normalized().cwiseProduct(image_axes));
  return targets;
}

template <int D>
std::vector<std::optional<Point<D>>> as_targets(const PointList<D>& p) {
  return std::vector<std::optional<Point<D>>>(p.begin(), p.end());
}

std::vector<std::optional<Point<2>>> targets_2d(const PhantomSpec<Phantom<2>>& image, const PhantomSpec<Template<2>>& tmpl,
                                                const Template<2>& t) {
  if (const auto* circle = tmpl.options_as<CircleTemplateOptions>()) {
    if (const auto* disk = image.options_as<DiskOptions>())
      return radial_targets<2>(t, circle->center, Point<2>::Ones(), disk->canvas.center_point(), Point<2>::Constant(disk->radius));
    if (const auto* square = image.options_as<SquareOptions>()) {
      // Radial correspondence (a convention): the square's boundary point on the ray from its
      // centre in the direction of the template vertex from the template's centre.
      const Point<2> center = square->canvas.center_point();
      const Eigen::Matrix2d R = Eigen::Rotation2Dd(square->rotation_deg * kPi / 180.0).toRotationMatrix();
      std::vector<std::optional<Point<2>>> targets;
      for (const auto& p : t.positions) {
        const Point<2> y = R.transpose() * (p - circle->center).normalized();
        targets.emplace_back(center + R * (y * square->half_width / std::max(std::abs(y.x()), std::abs(y.y()))));
      }
      return targets;
    }
  }
  const auto* image_star = image.options_as<StarImageOptions>();
  const auto* template_star = tmpl.options_as<StarTemplateOptions>();
  if (image_star && template_star && image_star->star.arms == template_star->star.arms)
    return as_targets<2>(star_polygon(image_star->canvas.center_point(), image_star->star));
  const auto* image_puzzle = image.options_as<PuzzleImageOptions>();
  if (image_puzzle && tmpl.options_as<PuzzleTemplateOptions>())
    return as_targets<2>(make_puzzle(image_puzzle->canvas.center_point(), image_puzzle->shape, t.num_vertices()).positions);
  const auto* image_slice = image.options_as<LungSliceImageOptions>();
  if (image_slice && tmpl.options_as<LungSliceTemplateOptions>())
    return as_targets<2>(make_lung_slice(image_slice->canvas.center_point(), image_slice->shape, t.num_vertices()).positions);
  return {};
}

// The semi-axes of a "sphere" or "ellipsoid" image or template phantom; nullopt for the others.
std::optional<Point<3>> image_axes(const PhantomSpec<Phantom<3>>& image) {
  if (const auto* o = image.options_as<SphereImageOptions>()) return Point<3>::Constant(o->radius);
  if (const auto* o = image.options_as<EllipsoidImageOptions>()) return o->semi_axes;
  return std::nullopt;
}
std::optional<std::pair<Point<3>, Point<3>>> template_center_axes(const PhantomSpec<Template<3>>& tmpl) {
  if (const auto* o = tmpl.options_as<SphereTemplateOptions>()) return std::pair{o->center, Point<3>::Constant(o->radius)};
  if (const auto* o = tmpl.options_as<EllipsoidTemplateOptions>()) return std::pair{o->center, o->semi_axes};
  return std::nullopt;
}

// The paper's 3D pairs: vertex k to the same vertex of the true shape.
std::optional<PointList<3>> paper_targets_3d(const PhantomSpec<Phantom<3>>& image, const PhantomSpec<Template<3>>& tmpl) {
  const auto* is = image.options_as<Star3dImageOptions>();
  if (const auto* ts = tmpl.options_as<Star3dTemplateOptions>(); is && ts)
    return make_star3d(is->canvas.center_point(), is->star, ts->subdivisions).positions;
  const auto* it = image.options_as<TetrisImageOptions>();
  if (it && tmpl.options_as<TetrisTemplateOptions>()) return make_tetris(it->canvas.center_point(), it->cell).positions;
  const auto* ib = image.options_as<BoneImageOptions>();
  if (const auto* tb = tmpl.options_as<BoneTemplateOptions>(); ib && tb)
    return make_bone(ib->canvas.center_point(), ib->bone, tb->subdivisions).positions;
  const auto* il = image.options_as<LungImageOptions>();
  if (const auto* tl = tmpl.options_as<LungTemplateOptions>(); il && tl)
    return make_lung(il->canvas.center_point(), il->shape, make_latlong_sphere(tl->rings, tl->segments)).positions;
  return std::nullopt;
}

std::vector<std::optional<Point<3>>> targets_3d(const PhantomSpec<Phantom<3>>& image, const PhantomSpec<Template<3>>& tmpl,
                                                const Template<3>& t) {
  if (const auto* bunny = tmpl.options_as<BunnyTemplateOptions>()) return bunny_targets(*bunny, t);
  if (const auto paper = paper_targets_3d(image, tmpl)) {
    DSNAKE_ASSERT(int(paper->size()) == t.num_vertices(), "paper targets: one per template vertex");
    return as_targets<3>(*paper);
  }
  const auto axes = image_axes(image);
  const auto frame = template_center_axes(tmpl);
  if (axes && frame) {
    const Point<3> center = image.options_as<SphereImageOptions>() ? image.options_as<SphereImageOptions>()->canvas.center_point()
                                                                   : image.options_as<EllipsoidImageOptions>()->canvas.center_point();
    return radial_targets<3>(t, frame->first, frame->second, center, *axes);
  }
  return {};
}

}  // namespace

template <>
std::vector<std::optional<Point<2>>> phantom_targets<2>(const PhantomSpec<Phantom<2>>& image, const PhantomSpec<Template<2>>& tmpl,
                                                        const Template<2>& t) {
  return targets_2d(image, tmpl, t);
}
template <>
std::vector<std::optional<Point<3>>> phantom_targets<3>(const PhantomSpec<Phantom<3>>& image, const PhantomSpec<Template<3>>& tmpl,
                                                        const Template<3>& t) {
  return targets_3d(image, tmpl, t);
}

template const PhantomRegistry<Phantom<2>>& image_phantoms<2>();
template const PhantomRegistry<Phantom<3>>& image_phantoms<3>();
template const PhantomRegistry<Template<2>>& template_phantoms<2>();
template const PhantomRegistry<Template<3>>& template_phantoms<3>();
template Phantom<2> make_phantom<2>(JsonReader&);
template Phantom<3> make_phantom<3>(JsonReader&);
template Template<2> make_template_phantom<2>(JsonReader&);
template Template<3> make_template_phantom<3>(JsonReader&);

}  // namespace dsnake
