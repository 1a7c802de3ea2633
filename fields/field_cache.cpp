// Field cache; see field_cache.h.
#include "fields/field_cache.h"

#include "framework/core/atomic_file.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake {

namespace {

// Two 64-bit FNV-1a-style hashes with different offsets and a final mix, over 8-byte words
// (fast on large volumes); together a 128-bit key.
struct Hash128 {
  uint64_t a = 0xcbf29ce484222325ull, b = 0x84222325cbf29ce4ull;
  void words(const void* data, size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    size_t i = 0;
    for (; i + 8 <= bytes; i += 8) {
      uint64_t w;
      std::memcpy(&w, p + i, 8);
      mix(w);
    }
    uint64_t tail = 0;
    std::memcpy(&tail, p + i, bytes - i);
    mix(tail ^ (uint64_t(bytes) << 56));
  }
  void mix(uint64_t w) {
    a = (a ^ w) * 0x100000001b3ull;
    b = (b ^ (w + 0x9e3779b97f4a7c15ull)) * 0x100000001b3ull;
    b ^= b >> 29;
  }
  static uint64_t finish(uint64_t x) {  // splitmix64 finaliser
    x ^= x >> 30, x *= 0xbf58476d1ce4e5b9ull, x ^= x >> 27, x *= 0x94d049bb133111ebull, x ^= x >> 31;
    return x;
  }
  std::string hex() const {
    char s[33];
    std::snprintf(s, sizeof s, "%016llx%016llx", (unsigned long long)finish(a), (unsigned long long)finish(b));
    return s;
  }
};

}  // namespace

template <int D>
std::string field_cache_key(const Image<D>& image, const std::string& type, const std::string& parameters) {
  Hash128 h;
  // The generation tag changes whenever a field's numerics change (2: the GVF solvers' padded
  // kernels and fused multigrid passes, last bits), so that a cache never serves a field that
  // this build would not compute bit for bit.
  const std::string head = "dsnake-field-cache-2 D=" + std::to_string(D) + " type=" + type + " " + parameters;
  h.words(head.data(), head.size());
  const Grid<D>& g = image.grid();
  for (int a = 0; a < D; ++a) {
    const double v[3] = {double(g.size[a]), g.spacing[a], g.origin[a]};
    h.words(v, sizeof v);
  }
  h.words(image.data().data(), image.data().size() * sizeof(float));
  return h.hex();
}

template <int D>
CachedField<D>::CachedField(std::unique_ptr<ExternalField<D>> field, std::string dir, std::string parameters)
    : field_(std::move(field)), dir_(std::move(dir)), parameters_(std::move(parameters)) {}

template <int D>
void CachedField<D>::compute(const Image<D>& image) {
  loaded_ = false;
  path_ = (std::filesystem::path(dir_) / (field_->type() + "-" + field_cache_key(image, field_->type(), parameters_) +
                                          ".field"))
              .string();
  {
    std::ifstream in(path_, std::ios::binary);
    if (in) {
      std::ostringstream bytes;
      bytes << in.rdbuf();
      if (field_->load_state(image.grid(), bytes.str())) {
        loaded_ = true;
        return;
      }
      std::fprintf(stderr, "warning: field cache entry %s does not fit; recomputing\n", path_.c_str());
    }
  }
  field_->compute(image);
  const std::string state = field_->save_state();
  if (state.empty()) return;  // this field cannot be cached
  try {
    std::filesystem::create_directories(dir_);
    write_file_atomically(path_, state);
  } catch (const std::exception& e) {  // a cache that cannot be written only costs time
    std::fprintf(stderr, "warning: cannot store the field in the cache: %s\n", e.what());
  }
}

template class CachedField<2>;
template class CachedField<3>;
template std::string field_cache_key(const Image<2>&, const std::string&, const std::string&);
template std::string field_cache_key(const Image<3>&, const std::string&, const std::string&);

}  // namespace dsnake
