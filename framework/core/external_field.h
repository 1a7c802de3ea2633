// ExternalField<D>: an image force field, computed once from the image and sampled at any
// physical point (linear interpolation). Fields that are the gradient of a potential (the basic
// edge-map field of §1) also expose it, for the energy trace and the global solve. What a field
// is stays small; storing its state (the field cache) and hints for large fields are optional
// interfaces beside it (CacheableField, LargeField), asked for through as_cacheable / as_large.
#pragma once

#include "framework/core/image.h"

#include <cstdint>
#include <limits>
#include <string>
#include <utility>

namespace dsnake {

template <int D>
class ExternalField {
 public:
  virtual ~ExternalField() = default;
  virtual std::string type() const = 0;

  // Computes the field from the image; may be slow (the field cache lives around it).
  virtual void compute(const Image<D>& image) = 0;
  // Checks the options against the grid the field will be computed on, before any work (such
  // as a VFC radius larger than the image); InputError naming the key. Default: nothing to check.
  virtual void check_grid(const Grid<D>& grid) const { (void)grid; }

  // The force at physical point x for a vertex with outward unit normal `normal` (only fields
  // with uses_normal(), such as DDGVF, look at it). Physical units per unit step.
  virtual Point<D> force(const Point<D>& x, const Point<D>& normal) const = 0;
  virtual bool uses_normal() const { return false; }

  // A potential P with force = -grad P, P >= 0, when the field has one; NaN otherwise.
  virtual bool has_potential() const { return false; }
  virtual double potential(const Point<D>& x) const { return std::numeric_limits<double>::quiet_NaN(); }

  // The sampled vectors on the image grid (for figures and `dsnake field`).
  virtual const VectorField<D>& vectors() const = 0;
};

// Optional interface of a field whose computed state can be stored and restored, so that the
// field cache (fields/field_cache.h) loads a second compute() on the same image and parameters
// instead of computing it. A field without it is computed every time.
template <int D>
class CacheableField {
 public:
  virtual ~CacheableField() = default;
  // The computed state as bytes ("": nothing to store).
  virtual std::string save_state() const = 0;
  // Restores a state written by save_state() for an image on `grid`; false if it does not fit.
  virtual bool load_state(const Grid<D>& grid, const std::string& bytes) = 0;
};

// Optional interface of a field whose data is large or made on demand (GVF and DDGVF on whole
// volumes): hints for memory and speed. None of them changes a result.
template <int D>
class LargeField {
 public:
  virtual ~LargeField() = default;
  // compute(image) for a caller that has no further use for the image: the field may release it
  // as soon as it has read it, so that the image's 4 bytes per voxel are not held through the
  // solve (`dsnake field`). The result is the same bits.
  virtual void compute_releasing(Image<D>&& image) = 0;
  // A hint that force(x, normal) follows soon: prefetches what it will read.
  virtual void prefetch(const Point<D>& x, const Point<D>& normal) const = 0;
  // The number of voxels the field is sampled on.
  virtual int64_t num_voxels() const = 0;
  // The largest |F| over the voxels, for a field that can tell it without making vectors()
  // (DDGVF makes its vectors on demand); NaN: max_force_magnitude (force_strength.h) reads
  // vectors().
  virtual double largest_vector_norm() const = 0;
};

// The optional interfaces of a field, or nullptr when it does not implement them.
template <int D>
const CacheableField<D>* as_cacheable(const ExternalField<D>& field) {
  return dynamic_cast<const CacheableField<D>*>(&field);
}
template <int D>
CacheableField<D>* as_cacheable(ExternalField<D>& field) {
  return dynamic_cast<CacheableField<D>*>(&field);
}
template <int D>
const LargeField<D>* as_large(const ExternalField<D>& field) {
  return dynamic_cast<const LargeField<D>*>(&field);
}

// What every field can be asked, with the optional interface where there is one and the plain
// field's answer otherwise.
template <int D>
void compute_releasing(ExternalField<D>& field, Image<D>&& image) {
  if (auto* large = dynamic_cast<LargeField<D>*>(&field)) large->compute_releasing(std::move(image));
  else field.compute(image);
}
template <int D>
int64_t field_voxels(const ExternalField<D>& field) {
  const LargeField<D>* large = as_large(field);
  return large != nullptr ? large->num_voxels() : field.vectors().num_voxels();
}
// `large` is as_large(field), looked up once by a caller that prefetches in a loop.
template <int D>
void prefetch_force(const ExternalField<D>& field, const LargeField<D>* large, const Point<D>& x, const Point<D>& normal) {
  if (large != nullptr) large->prefetch(x, normal);
  else field.vectors().prefetch(x);
}
template <int D>
double told_largest_vector_norm(const ExternalField<D>& field) {
  const LargeField<D>* large = as_large(field);
  return large != nullptr ? large->largest_vector_norm() : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace dsnake
