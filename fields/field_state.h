// Byte packing of a field's computed state for the field cache (fields/field_cache.h): a
// magic tag, the grid, then arrays of doubles or floats, each prefixed by its length. Small
// inline helpers shared by the field families; the reader checks every length, so a foreign or
// truncated file loads as "does not fit" instead of garbage.
#pragma once

#include "framework/core/image.h"

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace dsnake {

class StateWriter {
 public:
  explicit StateWriter(const std::string& tag) { raw(tag.data(), tag.size()); }
  template <class T>
  void value(const T& x) { raw(&x, sizeof(T)); }
  template <class T>
  void array(const std::vector<T>& a) {
    value<uint64_t>(a.size());
    raw(a.data(), a.size() * sizeof(T));
  }
  template <int D>
  void grid(const Grid<D>& g) {
    for (int a = 0; a < D; ++a) value<int32_t>(g.size[a]), value(g.spacing[a]), value(g.origin[a]);
  }
  template <int D>
  void vectors(const VectorField<D>& v) {
    value<uint64_t>(v.num_voxels());
    raw(v.data().data(), v.data().size() * sizeof(float));
  }
  std::string bytes() && { return std::move(bytes_); }

 private:
  void raw(const void* p, size_t n) { bytes_.append(static_cast<const char*>(p), n); }
  std::string bytes_;
};

class StateReader {
 public:
  // Fails (ok() false) unless the bytes start with `tag`.
  StateReader(const std::string& bytes, const std::string& tag) : bytes_(bytes) {
    ok_ = bytes.compare(0, tag.size(), tag) == 0;
    pos_ = tag.size();
  }
  bool ok() const { return ok_ && pos_ == bytes_.size(); }  // call at the end: all consumed
  template <class T>
  T value() {
    T x{};
    raw(&x, sizeof(T));
    return x;
  }
  template <class T>
  std::vector<T> array() {
    const uint64_t n = value<uint64_t>();
    if (!ok_ || n > (bytes_.size() - pos_) / sizeof(T)) return ok_ = false, std::vector<T>{};
    std::vector<T> a(n);
    raw(a.data(), n * sizeof(T));
    return a;
  }
  // True if the stored grid equals g.
  template <int D>
  bool grid(const Grid<D>& g) {
    bool same = true;
    for (int a = 0; a < D; ++a) {
      same &= value<int32_t>() == g.size[a];
      same &= value<double>() == g.spacing[a];
      same &= value<double>() == g.origin[a];
    }
    return ok_ &= same;
  }
  template <int D>
  VectorField<D> vectors(const Grid<D>& g) {
    VectorField<D> v(g);
    const uint64_t n = value<uint64_t>();
    if (!ok_ || n != uint64_t(v.num_voxels())) return ok_ = false, VectorField<D>{};
    raw(v.data().data(), v.data().size() * sizeof(float));
    return v;
  }
  bool fine() const { return ok_; }

 private:
  void raw(void* p, size_t n) {
    if (!ok_ || n > bytes_.size() - pos_) {
      ok_ = false;
      return;
    }
    std::memcpy(p, bytes_.data() + pos_, n);
    pos_ += n;
  }
  const std::string& bytes_;
  size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace dsnake
