// dsnake init; see init_command.h.
#include "experiments/cli/init_command.h"

#include "experiments/spec/assemble.h"
#include "experiments/spec/experiment.h"
#include "experiments/spec/experiment_spec.h"
#include "experiments/spec/recipe_scale.h"
#include "experiments/spec/recipes.h"
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

// True if `path` is a surface file of dimension D (else it is taken as a label image).
bool is_surface_file(const std::string& path, int dimension) {
  std::string e = fs::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  if (e == ".vtk") return true;
  if (dimension == 3) return e == ".off" || e == ".obj" || e == ".ply" || e == ".stl";
  return e == ".txt" || e == ".json";
}

// The recommended experiment: experiments/real/recipe_3d.json or recipe_2d_with_atlas.json with
// --reference, recipe_3d_without_atlas.json or recipe_2d_without_atlas.json without (compiled in,
// recipes.h), with only its inputs replaced: name, image, template (file; reference_image with
// --reference, and the recipe's template.init) and ground truth. Every setting is the recipe's, in
// mm, so that this file runs exactly what the project's real experiments run (REPRODUCTION.md),
// except that on a template smaller than the structures the recipe was measured on, its lengths are
// scaled to the template's size (experiments/spec/recipe_scale.h; one note on stderr says by how
// much). The recipe's lengths are chosen for scans with voxels of 0.3 to 3 mm (at that scale); on
// coarser voxels the patch forces are made as coarse as the voxels (coarsen_patches_to_voxels, one
// note), and otherwise outside that range a warning on stderr says so.
template <int D>
nlohmann::ordered_json recommended(const InitCommandOptions& o, const Grid<D>& grid, double radius) {
  const bool atlas = !o.reference.empty();
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(recipe_json(D, atlas));
  const std::string recipe_file = D == 3 ? (atlas ? "experiments/real/recipe_3d.json"
                                                   : "experiments/real/recipe_3d_without_atlas.json")
                                         : (atlas ? "experiments/real/recipe_2d_with_atlas.json"
                                                  : "experiments/real/recipe_2d_without_atlas.json");
  j["name"] = o.name.empty() ? fs::path(o.image).filename().string() : o.name;
  j["description"] = "Written by dsnake init for " + o.image + " and the template " + o.tmpl + ", from " +
                     recipe_file + ". " + j["description"].get<std::string>();
  j["image"] = {{"file", fs::absolute(o.image).string()}};
  if (o.read.nifti_transform != NiftiTransform::kAuto) j["image"]["nifti_transform"] = enum_name(o.read.nifti_transform);
  nlohmann::ordered_json tmpl = {{"file", fs::absolute(o.tmpl).string()}};
  if (atlas) {
    tmpl["reference_image"] = fs::absolute(o.reference).string();
    if (j["template"].contains("init")) tmpl["init"] = j["template"]["init"];
  }
  j["template"] = tmpl;
  // Without the recipe's ground truth. Not ordered_json::erase: nlohmann 3.11.2's ordered_map
  // erase leaks the erased value (found by LeakSanitizer; fixed upstream in 3.11.3).
  nlohmann::ordered_json kept = nlohmann::ordered_json::object();
  for (auto& [key, value] : j.items())
    if (key != "ground_truth") kept[key] = std::move(value);
  j = std::move(kept);
  if (!o.mask.empty())
    j["ground_truth"] = {{is_surface_file(o.mask, D) ? "surface" : "mask", fs::absolute(o.mask).string()}};
  if (!atlas)
    std::fprintf(stderr,
                 "dsnake: warning: no --reference: an atlas image (one in which the template sits on its object, e.g. "
                 "the scan the template was made from) is recommended; without it the forces see only edges, and a "
                 "boundary whose contrast changes side (darker than one neighbour, brighter than another) cannot be "
                 "followed, so this recipe only polishes the placed template: each vertex moves a little (max_travel) "
                 "and only where the edge evidence is clear%s\n",
                 D == 3 ? ""
                        : " (for an object brighter or darker than all of its surroundings and a contour placed by eye, "
                          "experiments/real/recipe_2d.json follows that one polarity onto it)");
  const double k = recipe_length_scale(radius);
  if (k < 1.0) {
    scale_lengths(j, D, k);
    char line[400];
    std::snprintf(line, sizeof line,
                  "the template's equivalent radius is %.3g mm, below the %.3g mm of the smallest structure the recipe "
                  "was measured on: every length in mm is scaled by %.3g (experiments/spec/recipe_scale.h)",
                  radius, kRecipeRadiusMm, k);
    j["description"] = j["description"].get<std::string>() + " Lengths: " + line + ".";
    std::fprintf(stderr, "dsnake: note: %s\n", line);
  }
  // The voxels in proportion to the (scaled) lengths: as if the structure had the recipe's size.
  const double h = grid.spacing.maxCoeff(), h_at_recipe_scale = h / k;
  const double coarsened = h_at_recipe_scale > kRecipeMaxVoxelMm ? coarsen_patches_to_voxels(j, D, h) : 1.0;
  if (coarsened > 1.0) {
    char line[400];
    std::snprintf(line, sizeof line,
                  "voxels of up to %.3g mm (%.3g at the recipe's scale), coarser than the recipe's 0.3 to %.3g mm: "
                  "each patch force's sigma is made at least a quarter of the largest voxel side, its radius and "
                  "spacing in proportion (the finest by %.3g); the other lengths stay as measured "
                  "(experiments/spec/recipe_scale.h)",
                  h, h_at_recipe_scale, kRecipeMaxVoxelMm, coarsened);
    j["description"] = j["description"].get<std::string>() + " Voxels: " + line + ".";
    std::fprintf(stderr, "dsnake: note: %s: %s\n", o.image.c_str(), line);
  } else if (h_at_recipe_scale < 0.3 || h_at_recipe_scale > kRecipeMaxVoxelMm)
    std::fprintf(stderr,
                 "dsnake: warning: %s: voxels of up to %.3g mm (%.3g at the recipe's scale); the recipe's lengths "
                 "(in mm: smoothing, profile and patch sizes, tolerances) were chosen on voxels of 0.3 to %.3g mm and "
                 "may fit less well here (REPRODUCTION.md, \"Other acquisitions\")\n",
                 o.image.c_str(), h, h_at_recipe_scale, kRecipeMaxVoxelMm);
  return j;
}

template <int D>
nlohmann::ordered_json init_experiment(const InitCommandOptions& o) {
  const Image<D> image = read_image<D>(o.image, o.read);
  // The template is read to refuse a bad one before anything is printed, and for its size.
  Template<D> tmpl;
  if constexpr (D == 3) tmpl = read_mesh_template(o.tmpl);
  else tmpl = read_contour_template(o.tmpl);
  const double radius = equivalent_radius<D>(tmpl);
  // Refused here as `dsnake run` would refuse the printed file (the template is placed as given).
  // With an atlas image the recipe first registers the whole atlas onto the whole scan
  // (template.init.whole_image), which brings a template lying on the atlas to the scan from
  // anywhere (a scan in its scanner's frame): the template must then lie near the atlas image.
  const bool from_atlas = !o.reference.empty();
  if (!from_atlas)
    if (const std::string what = outside_the_image<D>(tmpl.positions, image.grid()); !what.empty())
      throw InputError(o.tmpl, "--template", "the template " + what);
  if (const std::string what = smaller_than_a_voxel<D>(tmpl.positions, image.grid()); !what.empty())
    throw InputError(o.tmpl, "--template", "the template " + what);
  if (!o.mask.empty() && !is_surface_file(o.mask, D) && image_file_dimension(o.mask) != D)
    throw InputError(o.mask, "--mask", "expected a " + std::to_string(D) + "D label image like the image");
  if (!o.reference.empty() && image_file_dimension(o.reference) != D)
    throw InputError(o.reference, "--reference", "expected a " + std::to_string(D) + "D image like the image");
  // The atlas image is read whole (and let go) so that a file `dsnake run` would refuse (a NaN
  // voxel, truncated data) is named now, not after the user has written an experiment around it.
  if (!o.reference.empty()) {
    const Image<D> atlas = read_image<D>(o.reference, o.read);
    if (const std::string what = outside_the_image<D>(tmpl.positions, atlas.grid()); from_atlas && !what.empty())
      throw InputError(o.tmpl, "--template", "the template lies outside the atlas image " + o.reference +
                                                 " (--reference), on which it should lie: " + what.substr(what.find(": ") + 2));
  }
  nlohmann::ordered_json j = recommended<D>(o, image.grid(), radius);
  // The experiment reader checks the file as `dsnake validate` would.
  ExperimentFile file{"(dsnake init)", fs::current_path().string(), nlohmann::json::parse(j.dump()), D};
  read_experiment_spec<D>(file);
  return j;
}

}  // namespace

int run_init_command(const InitCommandOptions& o) {
  // (An empty path would reach the readers as a file without a name, refused without one.)
  if (o.image.empty()) throw InputError("", "--image", "must be a non-empty file name");
  if (o.tmpl.empty()) throw InputError("", "--template", "must be a non-empty file name");
  const int dimension = image_file_dimension(o.image);
  const nlohmann::ordered_json j = dimension == 3 ? init_experiment<3>(o) : init_experiment<2>(o);
  std::printf("%s\n", j.dump(2).c_str());
  return 0;
}

}  // namespace dsnake
