// The experiment file as typed values (docs/experiment-file.md is the contract): one plain
// struct per section, filled by small section readers that check every key and name the file
// and the JSON path of any problem. Nothing after reading looks at the JSON document again: the
// assembly (experiments/spec/assemble.h) builds the objects from these structs. Each section's
// keys are declared once, in a visit() (framework/core/options.h), from which come reading,
// checking, the schema and the documentation's key tables (experiments/spec/schema.h).
// Plug-ins (energies, the field, remeshing stages) are read into PluginSpecs and phantoms into
// PhantomSpecs (experiments/phantoms/phantom_registry.h): validated, not yet built.
#pragma once

#include "experiments/phantoms/corruption.h"
#include "experiments/phantoms/phantoms.h"
#include "experiments/spec/experiment.h"
#include "experiments/spec/template_init.h"
#include "fields/registry.h"

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace dsnake {

template <int D>
struct ImageSpec {
  std::string file;                                // resolved against the experiment file's folder
  std::optional<PhantomSpec<Phantom<D>>> phantom;  // exactly one of file and phantom
  std::vector<CorruptionSpec> corruptions;         // "corruption": applied in order
  ImageReadOptions read;  // "nifti_transform": for every image file the experiment reads
};

template <int D>
struct PlacementSpec {  // "template.transform": scale and rotation about the centroid, then translation
  double scale = 1.0;
  std::vector<double> rotation_deg;  // 2D: one angle; 3D: up to three (x, y, z)
  Point<D> translation = Point<D>::Zero();

  template <class V>
  void visit(V& v) {
    v(scale, Key{"scale", "1", "uniform scale about the template's centroid", Range::greater_than(0)});
    v(rotation_deg, Key{"rotation_deg", "degrees", "rotation about the centroid; 2D: one angle; 3D: up to three (about x, then y, then z)"});
    v(translation, Key{"translation", "mm", "added after scale and rotation"});
  }
  void check() const {
    if (int(rotation_deg.size()) > (D == 2 ? 1 : 3))
      throw OptionError{"rotation_deg", D == 2 ? "expected one angle" : "expected up to three angles (x, y, z)"};
  }
};

template <int D>
struct TemplateSpec {
  std::string file;
  std::optional<PhantomSpec<Template<D>>> phantom;
  VertexIds landmarks;  // checked against the template's size at assembly
  PlacementSpec<D> transform;
  std::string reference_image;  // "reference_image": resolved path, "" when absent
  std::optional<TemplateInitOptions> init;  // "template.init", after the transform (template_init.h)
  std::string start;  // "start": resolved path, "" when absent (in place of transform and init)

  // The section's own plain keys ("transform" and "init" are objects of their own).
  template <class V>
  void visit(V& v) {
    v(landmarks, Key{"landmarks", "", "named template vertices: {\"name\": vertex id}"});
    v(reference_image, Key{"reference_image", "",
                           "an image in which the template at its rest positions (as read) lies on its object (an "
                           "atlas, the previous slice): the profile energy's expected profiles are sampled there"});
    v(start, Key{"start", "",
                 "a contour (2D) or mesh (3D) file with the template's vertices in the template's order and its "
                 "edges or faces, whose positions (world mm) are the snake's start instead of the template placed "
                 "by transform and init (e.g. another registration's result carrying the template's vertices); the "
                 "rest positions stay the template's"});
  }
};

struct GroundTruthSpec {  // "ground_truth": files that override a phantom's own truth
  std::string mask, surface, correspondence;  // resolved paths; "" when absent

  template <class V>
  void visit(V& v) {
    v(mask, Key{"mask", "", "a label image (non-zero = inside) on any grid; one whose axes are turned against the image's is resampled along them (linear, inside at 0.5, a warning)"});
    v(surface, Key{"surface", "", "the true contour (2D) or mesh (3D)"});
    v(correspondence, Key{"correspondence", "", "a JSON file {\"targets\": [[x, y(, z)] | null, ...]}: the target of every template vertex"});
  }
};

struct EnergyWeight {  // "energies[i].weight", beside the energy's own keys
  double weight = 1.0;
  template <class V>
  void visit(V& v) {
    v(weight, Key{"weight", "1", "w_e of the term (§3.1's kappa, eta)", Range::greater_than(0)});
  }
};

template <int D>
struct EnergySpec : EnergyWeight {
  PluginSpec<Energy<D>> energy;
  std::string path;  // "energies[i]", for messages found at assembly
};

template <int D>
struct PhaseSpec : PhaseOptions {  // the phase's own keys (framework/core/phase_driver.h)
  std::vector<PluginSpec<Remesher<D>>> remesh;
};

template <int D>
struct ExperimentSpec : RunSettings {
  ExperimentFile file;  // path and folder for messages and relative paths; the document only for result.json's "config"
  ImageSpec<D> image;
  TemplateSpec<D> tmpl;
  GroundTruthSpec truth;
  FieldSpec<D> field;
  std::vector<EnergySpec<D>> energies;
  std::vector<PhaseSpec<D>> phases;
};

// Reads and checks every section; throws InputError naming the file and the JSON path.
template <int D>
ExperimentSpec<D> read_experiment_spec(const ExperimentFile& file);

}  // namespace dsnake
