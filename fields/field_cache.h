// The field cache: `"cache": "DIR"` in a field's JSON (or `--field-cache DIR` on the command
// line; read by read_field_spec, built by build_field in fields/registry.h) stores the computed
// field in DIR, keyed by a hash of the image (voxels and grid) and of the field's type and
// options (their canonical JSON, every key with its value), so that a sweep over snake settings
// computes each field once. CachedField<D> wraps any field that is a CacheableField: compute()
// loads DIR/<type>-<key>.field when it exists and fits, and otherwise computes and stores it
// (atomically: a killed run never leaves a half-written entry). Entries hold single-precision
// arrays of the region the field was computed on (fields/region.h); `"cache_compression":
// "zlib"` deflates new ones. A field that cannot save its
// state is computed every time. Everything else is forwarded to the wrapped field.
#pragma once

#include "framework/core/external_field.h"

#include <cstdint>
#include <memory>
#include <string>

namespace dsnake {

template <int D>
class CachedField final : public ExternalField<D>, public CacheableField<D>, public LargeField<D> {
 public:
  // `parameters`: a canonical text of the field's options (build_field: options_json(...).dump(),
  // every key, defaults made explicit).
  // `compressed`: new entries are deflated with zlib (either kind is read).
  CachedField(std::unique_ptr<ExternalField<D>> field, std::string dir, std::string parameters,
              bool compressed = false);

  std::string type() const override { return field_->type(); }
  void compute(const Image<D>& image) override;
  void compute_releasing(Image<D>&& image) override;
  void check_grid(const Grid<D>& grid) const override { field_->check_grid(grid); }
  Point<D> force(const Point<D>& x, const Point<D>& normal) const override { return field_->force(x, normal); }
  bool uses_normal() const override { return field_->uses_normal(); }
  bool has_potential() const override { return field_->has_potential(); }
  double potential(const Point<D>& x) const override { return field_->potential(x); }
  const VectorField<D>& vectors() const override { return field_->vectors(); }
  // The wrapped field's optional interfaces, or what a plain field answers.
  void prefetch(const Point<D>& x, const Point<D>& normal) const override { prefetch_force(*field_, large_, x, normal); }
  int64_t num_voxels() const override { return field_voxels(*field_); }
  double largest_vector_norm() const override { return told_largest_vector_norm(*field_); }
  std::string save_state() const override;
  bool load_state(const Grid<D>& grid, const std::string& bytes) override;

  // After compute(): whether the field came from the cache, and the entry's path.
  bool loaded_from_cache() const { return loaded_; }
  const std::string& entry_path() const { return path_; }
  const ExternalField<D>& field() const { return *field_; }

 private:
  bool load_entry(const Image<D>& image);
  void store_entry() const;

  std::unique_ptr<ExternalField<D>> field_;
  const LargeField<D>* large_ = nullptr;  // as_large(*field_)
  std::string dir_, parameters_, path_;
  bool loaded_ = false;
  bool compressed_ = false;
};

// The cache key: a 128-bit hash (hex) of the image's voxels and grid, the dimension, the field
// type and the parameters text.
template <int D>
std::string field_cache_key(const Image<D>& image, const std::string& type, const std::string& parameters);

}  // namespace dsnake
