// An experiment: the experiment file (docs/experiment-file.md is the contract) as loaded text
// with its --set overrides, and the ready-to-run objects assembled from it: the image (file or
// phantom, then seeded corruptions), the placed template, the ground truth, the external field,
// the weighted energies and the phases. Reading is experiments/spec/experiment_spec.h, building
// experiments/spec/assemble.h; make_experiment() does both. Every problem is an InputError naming
// the file and the JSON path; making an Experiment validates it completely without running.
#pragma once

#include "experiments/spec/template_init.h"
#include "framework/io/image_io.h"
#include "framework/core/evolver.h"
#include "fields/region.h"
#include "fields/smooth_potential.h"
#include "framework/core/external_field.h"
#include "framework/global/global_problem.h"
#include "framework/metrics/metrics.h"
#include "framework/core/options.h"
#include "framework/guard/collision_guard.h"
#include "registration/registration.h"

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace dsnake {

struct ExperimentFile {
  std::string path;           // as given, for messages ("" for a built-in experiment)
  std::string base_dir;       // relative paths in the file resolve against it
  nlohmann::json document;    // after --set overrides
  int dimension = 2;
};

// Parses an experiment file (syntax errors name the line and column) and applies overrides
// "key.path=value" (value parsed as JSON, else taken as a string; "energies[1].alpha=0.3").
ExperimentFile load_experiment_file(const std::string& path, const std::vector<std::string>& overrides = {});
// The built-in experiments: "default" (2D D-Snake, the paper's Fig. 4 lung slice), "classical" (2D
// classical snake, circle -> blurred square) and "ellipsoid" (3D).
ExperimentFile builtin_experiment(const std::string& name, const std::vector<std::string>& overrides = {});


// Thresholds: distances and errors at most, dice at least. Without a "success" object in the
// file, the defaults of the paper's robustness study apply: mean surface distance <= 1,
// HD95 <= 2, correspondence error max <= 2, Dice >= 0.9, no self-intersections, each only where
// the ground truth gives the metric.
struct SuccessCriteria {
  std::optional<double> mean_surface_distance, hausdorff95, hausdorff, dice;
  std::optional<double> correspondence_error_mean, correspondence_error_max;
  std::optional<int> self_intersections;
  bool skip_null_metrics = false;    // true for the defaults
  bool met(const Metrics& m) const;  // a threshold on a null metric is not met (unless skipped)
  // One threshold that a run's metrics did not meet: the metric's key, its value (null when
  // the ground truth does not give it), the comparison that failed ("<=" or ">=") and the limit.
  struct Failure {
    std::string metric;
    std::optional<double> value;
    std::string comparison;
    double threshold = 0;
    std::string describe() const;  // "dice 0.812 < 0.9", "hausdorff95 null (needs <= 2)"
  };
  // The thresholds not met, in the order of the keys; empty exactly when met(m).
  std::vector<Failure> failures(const Metrics& m) const;
  static SuccessCriteria defaults();

  template <class V>
  void visit(V& v) {
    v(mean_surface_distance, Key{"mean_surface_distance", "mm", "largest mean surface distance that counts as success", Range::at_least(0)});
    v(hausdorff95, Key{"hausdorff95", "mm", "largest 95th-percentile Hausdorff distance", Range::at_least(0)});
    v(hausdorff, Key{"hausdorff", "mm", "largest Hausdorff distance", Range::at_least(0)});
    v(dice, Key{"dice", "1", "smallest Dice overlap", Range::closed(0, 1)});
    v(correspondence_error_mean, Key{"correspondence_error_mean", "mm", "largest mean correspondence error", Range::at_least(0)});
    v(correspondence_error_max, Key{"correspondence_error_max", "mm", "largest correspondence error of any vertex", Range::at_least(0)});
    v(self_intersections, Key{"self_intersections", "pairs", "most self-intersecting edge or triangle pairs", Range::at_least(0)});
  }
};

// When a run writes the image it registered as image.nii.gz: "auto" when it is not a file read
// as it is (a phantom, or an image after corruptions), so that a user's own scan is not copied.
enum class ImageOutput { kAuto, kAlways, kNever };
template <>
struct EnumNames<ImageOutput> {
  static constexpr std::array<std::pair<ImageOutput, const char*>, 3> table{
      {{ImageOutput::kAuto, "auto"}, {ImageOutput::kAlways, "always"}, {ImageOutput::kNever, "never"}}};
};

struct OutputOptions {
  int snapshot_every = 0;   // write the snake every n iterations (0: never)
  bool figures = true;
  bool result_mask = true;  // result_mask.nii.gz: the result's interior on the image grid
  bool start_metrics = false;  // result.json's "start": the placed template's metrics
  ImageOutput image = ImageOutput::kAuto;
  bool report = true;  // `dsnake run`: the matplotlib figures and report.html (experiments/output/report_step.h)

  template <class V>
  void visit(V& v) {
    v(snapshot_every, Key{"snapshot_every", "iterations", "write the snake every n iterations into snapshots/ (0: never)", Range::at_least(0)});
    v(figures, Key{"figures", "", "write the PNG figures"});
    v(result_mask, Key{"result_mask", "", "write result_mask.nii.gz: the result's interior as a uint8 label map on the image file's own grid (its dimensions, voxel order and NIfTI header; a phantom's grid otherwise)"});
    v(start_metrics, Key{"start_metrics", "", "also measure the placed template (result.json's \"start\") and the snake at the end of every phase (\"phases\"[i].\"metrics\") against the ground truth, to see what each step gained; costs one more metrics pass each"});
    v(image, Key{"image", "", "write image.nii.gz, the image that was registered: auto (when it is a phantom or was corrupted), always or never"});
    v(report, Key{"report", "", "with figures, `dsnake run` also draws the matplotlib figures (energy terms, convergence, a 3D rendering of a mesh result coloured by its error) and writes report.html, the self-contained report with an interactive 3D view (python3: scripts/report/make_report.py, docs/reports.md); sweeps set it to false unless the experiment sets it"});
  }
};

// The run's own keys at the top level of the experiment file.
struct RunKeys {
  int dimension = 2;  // the file's; load_experiment_file() has chosen the reader's D from it
  std::string name, description;
  uint64_t seed = 0;
  SolverKind solver = SolverKind::kSnake;  // "solver": how a phase moves the snake (registration/registration.h)

  template <class V>
  void visit(V& v) {
    v(dimension, Key{"dimension", "", "2 (contour on an image) or 3 (mesh in a volume)", Range::closed(2, 3)});
    v(name, Key{"name", "", "names the default output folder out/<name>"});
    v(description, Key{"description", "", "free text"});
    v(seed, Key{"seed", "", "seeds the corruptions; same seed, same numbers", Range::at_least(0)});
    v(solver, Key{"solver", "", "the snake iteration of §3.1 or one global Ceres solve per phase"});
  }
};

// What the experiment file says about the run as a whole: the run keys and the run-level
// sections, read once into the spec (experiment_spec.h) and handed to the Experiment whole.
struct RunSettings : RunKeys {
  CollisionGuardOptions collision_guard;      // "collision_guard": the snake iteration's check
  GlobalSolverOptions global;                 // "global": Ceres' options
  std::optional<PotentialOptions> potential;  // the external term's potential (global view)
  SuccessCriteria success;
  OutputOptions output;
  MetricsOptions metrics;    // "metrics": how the surface distances are sampled
  WatchdogOptions watchdog;  // "watchdog": when a run is stopped as diverged
};

template <int D>
struct Experiment : RunSettings {
  ExperimentFile file;
  Image<D> image;
  bool image_is_file_as_read = false;  // a file without corruptions (so image.nii.gz would be a copy)
  // A file's image: how the file stores its voxels, so that the images written from it
  // (result_mask.nii.gz, image.nii.gz) are on its own grid (image_io.h, write_image_on_source_grid).
  std::optional<ImageLayout> image_layout;
  Template<D> tmpl;
  PointList<D> initial;  // the placed template: the snake's start
  // "template.reference_image": the template at its rest positions lies on its object there
  std::optional<Image<D>> reference_image;
  std::optional<InitReport<D>> init;  // what "template.init" did, if given (template_init.h)
  GroundTruth<D> truth;
  std::unique_ptr<ExternalField<D>> field;
  FieldRegionOptions field_region;  // "field.region": where the field is computed (fields/region.h)
  std::vector<WeightedEnergy<D>> energies;
  std::vector<Phase<D>> phases;
  std::vector<std::string> phase_names;  // the file's "name" of each phase, or "#k"
};

// Reads the file's sections (read_experiment_spec) and assembles the objects (assemble).
template <int D>
Experiment<D> make_experiment(const ExperimentFile& file);

}  // namespace dsnake
