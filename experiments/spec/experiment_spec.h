// The experiment file as typed values (docs/experiment-file.md is the contract): one plain
// struct per section, filled by small section readers that check every key and name the file
// and the JSON path of any problem. Nothing after reading looks at the JSON document again: the
// assembly (experiments/spec/assemble.h) builds the objects from these structs. Plug-ins (energies,
// the field, remeshing stages) are read into PluginSpecs, validated but not yet built.
// Phantoms are the exception that is kept as JSON: a phantom's keys depend on its family and
// are read by the phantom itself when the assembly renders it (experiments/phantoms/phantoms.h).
#pragma once

#include "experiments/phantoms/corruption.h"
#include "experiments/spec/experiment.h"
#include "experiments/spec/template_init.h"
#include "fields/registry.h"

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace dsnake {

// A phantom's section object (its "phantom" kind and parameters) with where it came from.
struct PhantomSource {
  nlohmann::json object;
  std::string file, path;
};

template <int D>
struct ImageSpec {
  std::string file;                      // resolved against the experiment file's folder
  std::optional<PhantomSource> phantom;  // exactly one of file and phantom
  std::vector<CorruptionSpec> corruptions;  // "corruption": applied in order
  ImageReadOptions read;  // "nifti_transform": for every image file the experiment reads
};

template <int D>
struct PlacementSpec {  // "template.transform": x -> scale R x + translation
  double scale = 1.0;
  std::vector<double> rotation_deg;  // 2D: one angle; 3D: up to three (x, y, z)
  Point<D> translation = Point<D>::Zero();
};

template <int D>
struct TemplateSpec {
  std::string file;
  std::optional<PhantomSource> phantom;
  std::map<std::string, int> landmarks;  // checked against the template's size at assembly
  PlacementSpec<D> transform;
  std::string reference_image;  // "reference_image": resolved path, "" when absent
  std::optional<TemplateInitOptions> init;  // "template.init", after the transform (template_init.h)
};

struct GroundTruthSpec {  // "ground_truth": files that override a phantom's own truth
  std::string mask, surface, correspondence;  // resolved paths; "" when absent
};

template <int D>
struct EnergySpec {
  double weight = 1.0;
  PluginSpec<Energy<D>> energy;
  std::string path;  // "energies[i]", for messages found at assembly
};

template <int D>
struct PhaseSpec {
  std::string name;  // "" when the file gives none
  int iterations = 100;
  double tolerance = 0.0;
  int every = 1;
  int window = 0;                  // the windowed stop (framework/core/stall.h); 0: off
  double energy_tolerance = 1e-3;  // its relative energy change
  std::vector<double> weights;  // one per energy, or empty
  std::vector<PluginSpec<Remesher<D>>> remesh;

  // The phase's own keys ("remesh" is read by the remesher registry).
  template <class V>
  void visit(V& v) {
    v(name, Key{"name", "", "shown in progress lines and result.json (default \"#k\")"});
    v(iterations, Key{"iterations", "iterations", "the phase's iteration budget (global solve: Ceres iterations are counted)", Range::closed(0, 10000000)});
    v(tolerance, Key{"tolerance", "mm", "stop when the largest vertex move of an iteration is below (0: never)", Range::at_least(0)});
    v(every, Key{"every", "iterations", "run the remeshing stages every `every` iterations", Range::at_least(1)});
    v(window, Key{"window", "iterations",
                  "the windowed stop (needs tolerance > 0; snake iteration only): every `window` iterations, stop when no "
                  "template vertex moved more than `tolerance` per iteration on the net once the centroid's motion is "
                  "removed, and the total energy changed by less than energy_tolerance of itself: a snake that only "
                  "slides or oscillates has converged (0: off)",
                  Range::closed(0, 10000000)});
    v(energy_tolerance, Key{"energy_tolerance", "1", "the windowed stop's largest relative change of the total energy over a window",
                            Range::at_least(0)});
    v(weights, Key{"weights", "1", "one weight per energy for this phase, in the energies' order (0 switches a term off); default: their own weights"});
  }
  void check() const {
    if (window > 0 && tolerance <= 0)
      throw OptionError{"window", "needs a tolerance > 0 (the net move per iteration below which the shape is still)"};
  }
};

template <int D>
struct ExperimentSpec {
  ExperimentFile file;  // path and folder for messages and relative paths; the document only for result.json's "config"
  std::string name, description;
  uint64_t seed = 0;
  SolverKind solver = SolverKind::kSnake;
  CollisionGuardOptions collision_guard;  // "collision_guard" (snake runs; on by default)
  GlobalSolverOptions global;
  std::optional<PotentialOptions> potential;
  ImageSpec<D> image;
  TemplateSpec<D> tmpl;
  GroundTruthSpec truth;
  FieldSpec<D> field;
  std::vector<EnergySpec<D>> energies;
  std::vector<PhaseSpec<D>> phases;
  SuccessCriteria success;
  OutputOptions output;
  MetricsOptions metrics;  // "metrics": how the surface distances are sampled
  WatchdogOptions watchdog;  // "watchdog": when a run is stopped as diverged
};

// Reads and checks every section; throws InputError naming the file and the JSON path.
template <int D>
ExperimentSpec<D> read_experiment_spec(const ExperimentFile& file);

}  // namespace dsnake
