// Energy<D>: one term E_e of the total energy E = sum_e w_e E_e, with two views of it.
//  - The snake view (§3.1): propose() gives, for every vertex the term governs, the position the
//    vertex would move to under this force alone. The Evolver averages the proposals with the
//    weights: q(t+1) = sum_e w_e propose_e(q(t)) / sum_e w_e over the terms governing a vertex.
//  - The global view: value() = E_e(q) = sum_k |r_k(q)|^2 over the residual blocks r_k that
//    add_residuals() puts into a global least-squares problem (Ceres; see global_problem.h).
// An energy never knows about the other energies.
#pragma once

#include "framework/core/shape.h"

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>

namespace dsnake {

template <int D> class ExternalField;
template <int D> class Image;
template <int D> class GlobalProblem;  // Ceres lives behind this in framework/global_problem.*
template <int D> class Potential;
template <int D> class SmoothedImageCache;  // framework/core/image_filters.h

// What an energy is bound to: the template and, where there is one, the image and its field.
template <int D>
struct EnergyContext {
  const Template<D>* tmpl = nullptr;
  const Image<D>* image = nullptr;
  const ExternalField<D>* field = nullptr;
  // The smooth potential of the external term's global view (framework/core/potential.h), if any.
  const Potential<D>* potential = nullptr;
  // "template.reference_image", if any: an image in which the template at its rest positions p
  // (as read) lies on its object (an atlas, the previous slice); the profile force samples its
  // expected profiles there (energies/profile.h).
  const Image<D>* reference_image = nullptr;
  // Smoothed images shared by the energies of the run (framework/core/image_filters.h), if any;
  // without one each energy smooths its own copy.
  SmoothedImageCache<D>* smoothed_images = nullptr;
};

enum class Governs {
  kAllVertices,          // every snake vertex (internal, external, balloon)
  kDeformationVertices,  // template vertices only (ASAP, §6: free vertices get no proposal)
  kMarkedVertices,       // the vertices governed_mask() marks (landmark springs): no other
                         // vertex's average includes the term
};

template <int D>
class Energy {
 public:
  virtual ~Energy() = default;
  virtual std::string type() const = 0;
  virtual Governs governs() const { return Governs::kAllVertices; }
  // For Governs::kMarkedVertices: one flag per snake vertex (non-zero: governed), valid from
  // bind() until the snake's topology changes; empty for the other kinds.
  virtual std::span<const uint8_t> governed_mask() const { return {}; }

  // Precomputes what depends on the template and the snake's connectivity. Called before the
  // first iteration and again whenever snake.topology_version() changes (after a remesh).
  virtual void bind(const EnergyContext<D>& context, const Snake<D>& snake) = 0;
  // Called at the start of every phase, after bind(), with the snake as the previous phase left
  // it; default: nothing. An energy whose rest shape is the snake at the phase's start (asap_mls
  // "rest": "phase_start") takes it here.
  virtual void begin_phase(const Snake<D>& snake) {}
  // Rules that depend on the template (e.g. a neighbourhood size): throws OptionError naming
  // the key. The experiment assembly calls it, so that the message names the file and path;
  // bind() may assume it passed.
  virtual void check_template(const Template<D>& tmpl) const {}
  // Whether bind() needs EnergyContext::reference_image (an atlas image); the experiment
  // assembly refuses such a term without "template.reference_image", naming it.
  virtual bool needs_reference_image() const { return false; }

  // Snake view: writes out[v] for every governed vertex v (out has num_vertices() entries;
  // entries of vertices not governed are left as they are).
  virtual void propose(const Snake<D>& snake, PointList<D>& out) = 0;

  // Global view: E_e(q) = sum of squared residuals; NaN where the term has no energy (an
  // external field without a potential).
  virtual double value(const Snake<D>& snake) const = 0;

  // Adds this term's residual blocks, scaled by sqrt(weight), to the problem. Returns false if
  // the term has no least-squares form (the global solver then reports a configuration error).
  virtual bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
    return false;
  }
  // Whether add_residuals() can succeed (the global solver checks this when it reads the file).
  virtual bool has_least_squares_form() const { return false; }

  // Distances this term measures on a snake, by name, mm, which a registration reports at its
  // start and its end (the landmark springs: each landmark's distance to its point, result.json's
  // "landmarks"). nullopt (the default): the term reports none. After bind().
  virtual std::optional<std::map<std::string, double>> reported_distances(const Snake<D>& snake) const {
    return std::nullopt;
  }
};

}  // namespace dsnake
