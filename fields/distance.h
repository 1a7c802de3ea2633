// The distance-potential force (Cohen & Cohen, "Finite-element methods for active contour
// models and balloons for 2-D and 3-D images", IEEE PAMI 1993), a baseline among D-Snake's
// external forces (Levi & Gotsman, §1): the potential P(x) = distance (physical units) to the
// nearest edge voxel and the force F = -grad P, which points at the nearest edge with unit
// magnitude from anywhere in the image. Edge voxels: edge map f >= threshold * max f.
// Exact Euclidean distance transform (separable lower envelopes of parabolas, Felzenszwalb &
// Huttenlocher 2012), spacing-aware.
#pragma once

#include "fields/edge_map.h"
#include "framework/core/external_field.h"

#include <string>

namespace dsnake {

struct DistanceFieldOptions {
  EdgeMapOptions edge;     // JSON: "sigma", "normalize"
  double threshold = 0.5;  // edge voxels: f >= threshold * max f

  template <class V>
  void visit(V& v) {
    edge.visit(v);
    v(threshold, Key{"threshold", "1 (fraction of max f)", "edge voxels: edge map f >= threshold x its maximum",
                     Range::open_closed(0, 1)});
  }
};

template <int D>
class DistanceField final : public ExternalField<D>, public CacheableField<D> {
 public:
  using Options = DistanceFieldOptions;
  static constexpr const char* kType = "distance";
  static constexpr const char* kSummary = "distance-potential force, Cohen & Cohen 1993 (a baseline of D-Snake §1)";

  explicit DistanceField(const DistanceFieldOptions& options = {});

  std::string type() const override { return kType; }
  const DistanceFieldOptions& options() const { return options_; }

  // Edge map, edge voxels, distance transform and its gradient. A constant image (no edges)
  // gives a zero field and a zero potential.
  void compute(const Image<D>& image) override;
  Point<D> force(const Point<D>& x, const Point<D>& normal) const override;
  bool has_potential() const override { return true; }
  // The distance to the nearest edge voxel, linearly interpolated.
  double potential(const Point<D>& x) const override;
  const VectorField<D>& vectors() const override { return vectors_; }
  const Image<D>& distance() const { return distance_; }

  std::string save_state() const override;
  bool load_state(const Grid<D>& grid, const std::string& bytes) override;

 private:
  DistanceFieldOptions options_;
  Image<D> distance_;
  VectorField<D> vectors_;
};

// Squared Euclidean distance (physical units) from every voxel to the nearest voxel with
// site[l] true; +infinity everywhere if there is none. Thread-count independent.
template <int D>
std::vector<double> squared_distance_transform(const Grid<D>& grid, const std::vector<bool>& site);

}  // namespace dsnake
