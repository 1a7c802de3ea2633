// ExternalField<D>: an image force field, computed once from the image and sampled at any
// physical point (linear interpolation). Fields that are the gradient of a potential (the basic
// edge-map field of §1) also expose it, for the energy trace and the global solve.
#pragma once

#include "framework/core/image.h"

#include <cstdint>
#include <limits>
#include <string>

namespace dsnake {

template <int D>
class ExternalField {
 public:
  virtual ~ExternalField() = default;
  virtual std::string type() const = 0;

  // Computes the field from the image; may be slow (the field cache lives around it).
  virtual void compute(const Image<D>& image) = 0;
  // compute(image) for a caller that has no further use for the image: a field may release it
  // as soon as it has read it, so that the image's 4 bytes per voxel are not held through the
  // solve (`dsnake field`). The result is the same bits. Default: compute(image).
  virtual void compute_releasing(Image<D>&& image) { compute(image); }
  // Checks the options against the grid the field will be computed on, before any work (such
  // as a VFC radius larger than the image); InputError naming the key. Default: nothing to check.
  virtual void check_grid(const Grid<D>& grid) const { (void)grid; }

  // The force at physical point x for a vertex with outward unit normal `normal` (only fields
  // with uses_normal(), such as DDGVF, look at it). Physical units per unit step.
  virtual Point<D> force(const Point<D>& x, const Point<D>& normal) const = 0;
  virtual bool uses_normal() const { return false; }
  // A hint that force(x, normal) follows soon: prefetches what it will read (by default the
  // voxels of vectors() around x). Never changes a result.
  virtual void prefetch(const Point<D>& x, const Point<D>& normal) const {
    (void)normal;
    vectors().prefetch(x);
  }

  // A potential P with force = -grad P, P >= 0, when the field has one; NaN otherwise.
  virtual bool has_potential() const { return false; }
  virtual double potential(const Point<D>& x) const { return std::numeric_limits<double>::quiet_NaN(); }

  // The sampled vectors on the image grid (for figures and `dsnake field`).
  virtual const VectorField<D>& vectors() const = 0;
  // The number of voxels the field is sampled on (by default those of vectors()).
  virtual int64_t num_voxels() const { return vectors().num_voxels(); }
  // The largest |F| over the voxels of vectors(), for a field that can tell it without making
  // them (DDGVF makes its vectors on demand); NaN: max_force_magnitude
  // (force_strength.h) reads vectors().
  virtual double largest_vector_norm() const { return std::numeric_limits<double>::quiet_NaN(); }

  // Field cache support (fields/field_cache.h): the computed state as bytes, and back, so that
  // a second compute() on the same image and parameters loads instead of computing. A field
  // that cannot be cached returns "" (it is then computed every time).
  virtual std::string save_state() const { return {}; }
  // Restores a state written by save_state() for an image on `grid`; false if it does not fit.
  virtual bool load_state(const Grid<D>& grid, const std::string& bytes) { return false; }
};

}  // namespace dsnake
