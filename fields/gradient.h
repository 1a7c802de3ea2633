// The basic external field of Levi & Gotsman, D-Snake, §1: E_ext = -|grad I|^2, after Kass,
// Witkin and Terzopoulos, "Snakes: Active contour models" (1988). The edge map
// f = |grad (G_sigma * I)|^2 (optionally normalised to [0, 1]) gives the force F = grad f and the
// potential P = max(f) - f >= 0, so that F = -grad P. Everything is in physical units: the
// Gaussian's sigma is in mm and derivatives divide by the spacing, so an anisotropic image gives
// the same field as an isotropic one of the same object.
#pragma once

#include "framework/core/external_field.h"
#include "framework/core/options.h"

#include <string>

namespace dsnake {

struct GradientFieldOptions {
  double sigma = 1.0;      // Gaussian pre-smoothing, standard deviation in physical units
                           // (0: no smoothing)
  bool normalize = true;   // scale the edge map to [0, 1] by its maximum

  template <class V>
  void visit(V& v) {
    v(sigma, Key{"sigma", "mm", "Gaussian pre-smoothing of the image before the edge map, standard deviation (0: none)",
                 Range::at_least(0)});
    v(normalize, Key{"normalize", "", "scale the edge map f = |grad(G_sigma * I)|^2 to [0, 1] by its maximum"});
  }
};

template <int D>
class GradientField final : public ExternalField<D> {
 public:
  using Options = GradientFieldOptions;
  static constexpr const char* kType = "gradient";
  static constexpr const char* kSummary =
      "the edge-map gradient F = grad |grad(G_sigma * I)|^2, Kass, Witkin & Terzopoulos 1988 (D-Snake §1)";

  explicit GradientField(const GradientFieldOptions& options = {});

  std::string type() const override { return kType; }
  const GradientFieldOptions& options() const { return options_; }

  // Blurs, builds the edge map f and its gradient on the image grid. Parallel over voxels;
  // the result does not depend on the number of threads.
  void compute(const Image<D>& image) override;

  // grad f at x, linearly interpolated (the normal is not used).
  Point<D> force(const Point<D>& x, const Point<D>& normal) const override;

  bool has_potential() const override { return true; }
  // P(x) = max(f) - f(x) >= 0, f linearly interpolated (1 - f when normalised).
  double potential(const Point<D>& x) const override;

  const VectorField<D>& vectors() const override { return vectors_; }
  // The edge map f on the image grid (for figures and tests).
  const Image<D>& edge_map() const { return edge_map_; }

 private:
  GradientFieldOptions options_;
  Image<D> edge_map_;
  double edge_max_ = 0.0;
  VectorField<D> vectors_;
};

}  // namespace dsnake
