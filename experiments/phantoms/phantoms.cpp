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
PhantomCanvas<D> read_canvas(JsonReader& r, const GridIndex<D>& default_size, double default_blur) {
  PhantomCanvas<D> c;
  c.blur = default_blur;
  std::vector<double> size(default_size.data(), default_size.data() + D);
  r.read("size", size);
  r.expect(int(size.size()) == D, "size", "expected " + std::to_string(D) + " integers");
  for (int a = 0; a < D; ++a) {
    r.expect(size[a] >= 4 && size[a] <= 4096 && size[a] == std::floor(size[a]), "size",
             "each size must be an integer in [4, 4096]");
    c.grid.size[a] = static_cast<int>(size[a]);
  }
  r.read<D>("spacing", c.grid.spacing);
  r.expect(c.grid.spacing.minCoeff() > 0, "spacing", "must be > 0");
  r.read<D>("origin", c.grid.origin);
  r.read("foreground", c.foreground);
  r.read("background", c.background);
  r.read("blur", c.blur);
  r.expect(c.blur >= 0, "blur", "must be >= 0");
  r.read("partial_volume", c.partial_volume);
  c.center = c.grid.origin + 0.5 * (c.grid.size.template cast<double>() - Point<D>::Ones()).cwiseProduct(c.grid.spacing);
  r.read<D>("center", c.center);
  return c;
}

// Default image size (voxels per axis), blur and template centre (the default image's centre)
// of a phantom kind. The paper's phantoms (§8) are binary by default (blur 0), as the paper's
// corruptions expect; the older ones keep a blur of 1.
template <int D>
constexpr int kDefaultImageSize = D == 2 ? 128 : 64;
template <int D>
GridIndex<D> default_image_size(const std::string& kind) {
  const GridIndex<D> paper = paper_image_size<D>(kind);
  return paper.minCoeff() > 0 ? paper : GridIndex<D>::Constant(kDefaultImageSize<D>);
}
template <int D>
double default_blur(const std::string& kind) {
  return paper_image_size<D>(kind).minCoeff() > 0 ? 0.0 : 1.0;
}
template <int D>
Point<D> default_template_center(const std::string& kind) {
  return 0.5 * (default_image_size<D>(kind).template cast<double>() - Point<D>::Ones());
}

// The parameters of a star shape, shared by the image and the template phantom.
struct StarShape {
  int arms = 5;
  double outer = 40, inner = 18, rotation_deg = 90;
};

StarShape read_star(JsonReader& r) {
  StarShape s;
  r.read("arms", s.arms);
  r.read("outer_radius", s.outer);
  r.read("inner_radius", s.inner);
  r.read("rotation_deg", s.rotation_deg);
  r.expect(s.arms >= 3 && s.arms <= 64, "arms", "must be in [3, 64]");
  r.expect(s.outer > 0, "outer_radius", "must be > 0");
  r.expect(s.inner > 0 && s.inner < s.outer, "inner_radius", "must be in (0, outer_radius)");
  return s;
}

// Semi-axes of a "sphere" (key radius) or an "ellipsoid" (key semi_axes); fails on other kinds.
Point<3> read_axes(JsonReader& r, const std::string& kind, double default_radius, const char* role) {
  Point<3> axes;
  if (kind == "sphere") {
    double radius = default_radius;
    r.read("radius", radius);
    r.expect(radius > 0, "radius", "must be > 0");
    axes.setConstant(radius);
  } else if (kind == "ellipsoid") {
    axes = Point<3>(24, 16, 12);
    r.read<3>("semi_axes", axes);
    r.expect(axes.minCoeff() > 0, "semi_axes", "must be > 0");
  } else {
    r.fail("phantom", "unknown 3D " + std::string(role) + " phantom \"" + kind + "\" (known: sphere, ellipsoid, " +
                          (std::string(role) == "image" ? paper_image_kinds<3>() + ", mesh, points" : paper_template_kinds<3>() + ", bunny") + ")");
  }
  return axes;
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

template <>
Phantom<2> make_phantom<2>(JsonReader& r) {
  std::string kind;
  r.require("phantom", kind);
  Phantom<2> ph;
  ph.kind = kind;
  auto c = read_canvas<2>(r, default_image_size<2>(kind), default_blur<2>(kind));
  if (auto shape = make_paper_image<2>(r, kind, c.center)) {
    render_surface<2>(ph, c, *shape);
  } else if (kind == "disk") {
    double radius = 30;
    r.read("radius", radius);
    r.expect(radius > 0, "radius", "must be > 0");
    render<2>(ph, c, [&](const Point<2>& x) { return (x - c.center).norm() < radius; });
    ph.surface = polygon_template(circle_points(c.center, radius, 1024));
  } else if (kind == "square") {
    double half = 30, rotation = 0;
    r.read("half_width", half);
    r.read("rotation_deg", rotation);
    r.expect(half > 0, "half_width", "must be > 0");
    const double a = rotation * kPi / 180.0;
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(a).toRotationMatrix();
    render<2>(ph, c, [&](const Point<2>& x) {
      const Point<2> y = R.transpose() * (x - c.center);
      return std::max(std::abs(y.x()), std::abs(y.y())) < half;
    });
    PointList<2> p;
    const Point<2> corners[4] = {{half, -half}, {half, half}, {-half, half}, {-half, -half}};
    constexpr int kPerSide = 128;
    for (int s = 0; s < 4; ++s)
      for (int k = 0; k < kPerSide; ++k) {
        const double t = double(k) / kPerSide;
        p.push_back(c.center + R * ((1 - t) * corners[s] + t * corners[(s + 1) % 4]));
      }
    ph.surface = polygon_template(std::move(p));
  } else if (kind == "star") {
    const PointList<2> poly = star_polygon(c.center, read_star(r));
    render<2>(ph, c, [&](const Point<2>& x) { return inside_polygon(poly, x); });
    ph.surface = polygon_template(poly);
  } else {
    r.fail("phantom", "unknown 2D image phantom \"" + kind + "\" (known: disk, square, star, " +
                          paper_image_kinds<2>() + ")");
  }
  return ph;
}

template <>
Phantom<3> make_phantom<3>(JsonReader& r) {
  std::string kind;
  r.require("phantom", kind);
  Phantom<3> ph;
  ph.kind = kind;
  if (const GridIndex<3> size = mesh_image_size(r, kind); size.minCoeff() > 0) {  // experiments/phantoms/bunny.h
    const auto c = read_canvas<3>(r, size, 0.0);
    render_surface<3>(ph, c, PaperImageShape<3>{*make_mesh_image_surface(r, kind, c.center), {}});
    return ph;
  }
  auto c = read_canvas<3>(r, default_image_size<3>(kind), default_blur<3>(kind));
  if (auto shape = make_paper_image<3>(r, kind, c.center)) {
    render_surface<3>(ph, c, *shape);
    return ph;
  }
  const Point<3> axes = read_axes(r, kind, 20, "image");
  render<3>(ph, c, [&](const Point<3>& x) { return (x - c.center).cwiseQuotient(axes).squaredNorm() < 1.0; });
  ph.surface = scaled_icosphere(5, c.center, axes);
  return ph;
}

template <>
Template<2> make_template_phantom<2>(JsonReader& r) {
  std::string kind;
  r.require("phantom", kind);
  Point<2> center = default_template_center<2>(kind);
  r.read<2>("center", center);
  if (auto t = make_paper_template<2>(r, kind, center)) return std::move(*t);
  if (kind == "circle") {
    double radius = 40;
    int vertices = 40;
    r.read("radius", radius);
    r.read("vertices", vertices);
    r.expect(radius > 0, "radius", "must be > 0");
    r.expect(vertices >= 3 && vertices <= 100000, "vertices", "must be in [3, 100000]");
    return polygon_template(circle_points(center, radius, vertices));
  }
  if (kind == "star") {
    const StarShape star = read_star(r);
    Template<2> t = polygon_template(star_polygon(center, star));
    for (int k = 0; k < star.arms; ++k) t.landmarks["tip" + std::to_string(k)] = 2 * k;
    return t;
  }
  r.fail("phantom", "unknown 2D template phantom \"" + kind + "\" (known: circle, star, " +
                        paper_template_kinds<2>() + ")");
}

template <>
Template<3> make_template_phantom<3>(JsonReader& r) {
  std::string kind;
  r.require("phantom", kind);
  if (auto t = make_bunny_template(r, kind)) return std::move(*t);  // experiments/phantoms/bunny.h
  Point<3> center = default_template_center<3>(kind);
  r.read<3>("center", center);
  if (auto t = make_paper_template<3>(r, kind, center)) return std::move(*t);
  int subdivisions = 2;
  r.read("subdivisions", subdivisions);
  r.expect(subdivisions >= 0 && subdivisions <= 6, "subdivisions", "must be in [0, 6]");
  const Point<3> axes = read_axes(r, kind, 24, "template");
  Template<3> t = scaled_icosphere(subdivisions, center, axes);
  const char* names[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};
  for (int k = 0; k < 6; ++k) {  // the six axis extremes, as landmarks
    int best = 0;
    const double sign = k % 2 == 0 ? 1.0 : -1.0;
    for (int v = 1; v < t.num_vertices(); ++v)
      if (sign * (t.positions[v][k / 2] - t.positions[best][k / 2]) > 0) best = v;
    t.landmarks[names[k]] = best;
  }
  return t;
}

template <int D>
std::vector<std::optional<Point<D>>> phantom_targets(const nlohmann::json& image_spec,
                                                     const nlohmann::json& template_spec,
                                                     const Template<D>& tmpl) {
  std::vector<std::optional<Point<D>>> targets;
  if (!image_spec.is_object() || !template_spec.is_object() || !image_spec.contains("phantom") ||
      !template_spec.contains("phantom"))
    return targets;
  // Rebuild both phantoms' defaults through readers (the specs were validated already).
  nlohmann::json img = image_spec, tpl = template_spec;
  img.erase("file");
  tpl.erase("transform");
  const std::string ik = img.value("phantom", ""), tk = tpl.value("phantom", "");
  JsonReader ir(img, "", "image"), tr(tpl, "", "template");
  if constexpr (D == 3)
    if (tk == "bunny") return bunny_targets(tr, tmpl);  // experiments/phantoms/bunny.h
  const auto canvas = read_canvas<D>(ir, default_image_size<D>(ik), default_blur<D>(ik));
  Point<D> template_center = default_template_center<D>(tk);
  tr.read<D>("center", template_center);
  if (auto paper = paper_targets<D>(ir, ik, canvas.center, tr, tk, tmpl)) return std::move(*paper);

  // The template's direction in its own ellipsoid frame, mapped onto the image's ellipsoid.
  auto radial = [&](const Point<D>& axes) {
    Point<D> template_axes = Point<D>::Ones();
    if constexpr (D == 3) template_axes = read_axes(tr, tk, 24, "template");
    for (const auto& p : tmpl.positions)
      targets.emplace_back(canvas.center + (p - template_center).cwiseQuotient(template_axes).normalized().cwiseProduct(axes));
  };
  if constexpr (D == 2) {
    if (tk == "circle" && ik == "disk") {
      radial(Point<2>::Constant(img.value("radius", 30.0)));
    } else if (tk == "circle" && ik == "square") {
      // Radial correspondence (a convention): the square's boundary point on the ray from its
      // centre in the direction of the template vertex from the template's centre.
      const double half = img.value("half_width", 30.0);
      const Eigen::Matrix2d R = Eigen::Rotation2Dd(img.value("rotation_deg", 0.0) * kPi / 180.0).toRotationMatrix();
      for (const auto& p : tmpl.positions) {
        const Point<2> y = R.transpose() * (p - template_center).normalized();
        targets.emplace_back(canvas.center + R * (y * half / std::max(std::abs(y.x()), std::abs(y.y()))));
      }
    } else if (tk == "star" && ik == "star") {
      const StarShape image_star = read_star(ir), template_star = read_star(tr);
      if (image_star.arms == template_star.arms)
        for (const auto& p : star_polygon(canvas.center, image_star)) targets.emplace_back(p);
    }
  } else {
    if ((tk == "sphere" || tk == "ellipsoid") && (ik == "sphere" || ik == "ellipsoid"))
      radial(read_axes(ir, ik, 20, "image"));
  }
  return targets;
}

template std::vector<std::optional<Point<2>>> phantom_targets<2>(const nlohmann::json&, const nlohmann::json&,
                                                                 const Template<2>&);
template std::vector<std::optional<Point<3>>> phantom_targets<3>(const nlohmann::json&, const nlohmann::json&,
                                                                 const Template<3>&);

template <>
std::vector<std::string> image_phantom_kinds<2>() { return {"disk", "square", "star", "puzzle", "lung_slice"}; }
template <>
std::vector<std::string> image_phantom_kinds<3>() {
  return {"sphere", "ellipsoid", "star", "tetris", "lung", "bone", "mesh", "points"};
}
template <>
std::vector<std::string> template_phantom_kinds<2>() { return {"circle", "star", "puzzle", "lung_slice"}; }
template <>
std::vector<std::string> template_phantom_kinds<3>() {
  return {"sphere", "ellipsoid", "star", "tetris", "bar", "c_shape", "lung", "bone", "bunny"};
}

}  // namespace dsnake
