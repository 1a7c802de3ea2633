// dsnake init; see init_command.h.
#include "experiments/init_command.h"

#include "experiments/experiment.h"
#include "experiments/experiment_spec.h"
#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace dsnake {

namespace {

namespace fs = std::filesystem;

// Rounds to 3 significant digits, so that the file reads as chosen numbers.
double tidy(double v) {
  if (v == 0 || !std::isfinite(v)) return v;
  const double scale = std::pow(10.0, 2 - std::floor(std::log10(std::abs(v))));
  return std::round(v * scale) / scale;
}

// Mean edge length of a template (mm).
template <int D>
double mean_edge(const Template<D>& t) {
  double sum = 0;
  int n = 0;
  for (const auto& [a, b] : t.connectivity.edges()) {
    sum += (t.positions[a] - t.positions[b]).norm();
    ++n;
  }
  return n ? sum / n : 1.0;
}

// True if `path` is a surface file of dimension D (else it is taken as a label image).
bool is_surface_file(const std::string& path, int dimension) {
  std::string e = fs::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  if (e == ".vtk") return true;
  if (dimension == 3) return e == ".off" || e == ".obj" || e == ".ply" || e == ".stl";
  return e == ".txt" || e == ".json";
}

// The recommended experiment (a D-Snake, §3) for an image with voxel size h (the largest
// spacing, mm) and a template with mean edge length l (mm):
//  - field: GVF (a capture range beyond the edges, §1) of the edge map after Gaussian smoothing
//    with sigma = 1.5 h;
//  - internal: alpha 0.1 mm^2, beta 0 (3D) / 0.01 mm^4 (2D), physical units (issue 19): a weak
//    tension; external: "normalize": "max", tau = h / 2, so that a vertex where the force is
//    strongest steps half a voxel (times the weights' share, 1 / 2.5);
//  - ASAP-MLS, approximate, 2 rings, weight 0.5: the template's local shape (§2);
//  - fit: 300 iterations, tolerance 0.01 h; refine: 100 iterations, remeshing every 5 to keep
//    edges near l (3D: refine above 1.5 l, Delaunay flips, uniform relaxation, simplify; 2D:
//    resampling to [0.5 l, 1.5 l]).
template <int D>
nlohmann::ordered_json recommended(const InitCommandOptions& o, const Grid<D>& grid, double l) {
  const double h = grid.spacing.maxCoeff();
  const double sigma = tidy(1.5 * h);
  nlohmann::ordered_json j;
  j["name"] = o.name.empty() ? fs::path(o.image).filename().string() : o.name;
  char description[1024];
  std::snprintf(description, sizeof(description),
                "Written by dsnake init for %s (voxel size up to %.3g mm) and the template %s (mean edge %.3g mm). "
                "A D-Snake: internal + external (GVF of the edge map smoothed by sigma = 1.5 voxels = %.3g mm; step "
                "tau = half a voxel where the force is strongest) + approximate ASAP-MLS over 2 rings, which keeps the template's local shape. Phase fit: "
                "300 iterations; phase refine: remeshing every 5 iterations keeps edges near the template's. Edit "
                "template.transform if the template does not start roughly on the object; docs/experiment-file.md "
                "lists every key with its unit and range.",
                o.image.c_str(), h, o.tmpl.c_str(), l, sigma);
  j["description"] = description;
  j["dimension"] = D;
  j["seed"] = 1;
  j["image"] = {{"file", fs::absolute(o.image).string()}};
  j["template"] = {{"file", fs::absolute(o.tmpl).string()}};
  j["field"] = {{"type", "gvf"}, {"sigma", sigma}};
  j["energies"] = nlohmann::ordered_json::array(
      {{{"type", "internal"}, {"weight", 1.0}, {"alpha", 0.1}, {"beta", D == 3 ? 0.0 : 0.01}},
       {{"type", "external"}, {"weight", 1.0}, {"tau", tidy(0.5 * h)}, {"normalize", "max"}},
       {{"type", "asap_mls"}, {"weight", 0.5}, {"variant", "approximate"}, {"neighborhood", "rings"}, {"rings", 2}}});
  nlohmann::ordered_json remesh;
  if constexpr (D == 3)
    remesh = nlohmann::ordered_json::array({{{"type", "refine"}, {"max_edge", tidy(1.5 * l)}},
                                            {{"type", "delaunay"}}, {{"type", "uniform"}}, {{"type", "simplify"}}});
  else
    remesh = nlohmann::ordered_json::array({{{"type", "resample"}, {"min_edge", tidy(0.5 * l)}, {"max_edge", tidy(1.5 * l)}}});
  j["phases"] = nlohmann::ordered_json::array(
      {{{"name", "fit"}, {"iterations", 300}, {"tolerance", tidy(0.01 * h)}},
       {{"name", "refine"}, {"iterations", 100}, {"tolerance", tidy(0.01 * h)}, {"every", 5}, {"remesh", remesh}}});
  if (!o.mask.empty())
    j["ground_truth"] = {{is_surface_file(o.mask, D) ? "surface" : "mask", fs::absolute(o.mask).string()}};
  return j;
}

template <int D>
nlohmann::ordered_json init_experiment(const InitCommandOptions& o) {
  const Image<D> image = read_image<D>(o.image);
  Template<D> t;
  if constexpr (D == 3) t = read_mesh_template(o.tmpl);
  else t = read_contour_template(o.tmpl);
  if (!o.mask.empty() && !is_surface_file(o.mask, D) && image_file_dimension(o.mask) != D)
    throw InputError(o.mask, "--mask", "expected a " + std::to_string(D) + "D label image like the image");
  nlohmann::ordered_json j = recommended<D>(o, image.grid(), mean_edge(t));
  // The experiment reader checks the file as `dsnake validate` would.
  ExperimentFile file{"(dsnake init)", fs::current_path().string(), nlohmann::json::parse(j.dump()), D};
  read_experiment_spec<D>(file);
  return j;
}

}  // namespace

int run_init_command(const InitCommandOptions& o) {
  const int dimension = image_file_dimension(o.image);
  const nlohmann::ordered_json j = dimension == 3 ? init_experiment<3>(o) : init_experiment<2>(o);
  std::printf("%s\n", j.dump(2).c_str());
  return 0;
}

}  // namespace dsnake
