// Field cache; see field_cache.h.
#include "fields/field_cache.h"

#include "framework/core/atomic_file.h"

#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <filesystem>

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

// A deflated entry: this tag, the inflated size (8 bytes), then zlib's stream of the state's
// bytes shuffled by 4: byte k of every 4-byte word together (k = 0..3). The state is mostly
// float arrays; their sign-and-exponent bytes, side by side, are what deflate can shrink.
constexpr char kDeflatedTag[] = "dsnake-deflated-1";
constexpr size_t kDeflatedTagSize = sizeof(kDeflatedTag) - 1;

// Byte k of word w goes to k * words + w (the tail of fewer than 4 bytes stays in place), or
// back with `inverse`.
std::string shuffled(const std::string& in, bool inverse) {
  std::string out(in.size(), '\0');
  const size_t words = in.size() / 4;
  for (size_t w = 0; w < words; ++w)
    for (size_t k = 0; k < 4; ++k) {
      const size_t plain = 4 * w + k, grouped = k * words + w;
      out[inverse ? plain : grouped] = in[inverse ? grouped : plain];
    }
  for (size_t i = 4 * words; i < in.size(); ++i) out[i] = in[i];
  return out;
}

std::string deflated(const std::string& bytes) {
  const std::string plain = shuffled(bytes, false);
  uLongf size = compressBound(plain.size());
  std::string out(kDeflatedTagSize + 8 + size, '\0');
  std::memcpy(out.data(), kDeflatedTag, kDeflatedTagSize);
  const uint64_t n = plain.size();
  std::memcpy(out.data() + kDeflatedTagSize, &n, 8);
  auto* dst = reinterpret_cast<Bytef*>(out.data() + kDeflatedTagSize + 8);
  if (compress2(dst, &size, reinterpret_cast<const Bytef*>(plain.data()), plain.size(), Z_BEST_SPEED) != Z_OK)
    return bytes;  // stored raw: still a valid entry
  out.resize(kDeflatedTagSize + 8 + size);
  return out;
}

// The entry's state bytes: inflated if it was deflated. An inflated size above `max_bytes`
// (more than this grid's state can hold) or a broken stream gives "" (does not fit), before
// anything that large is allocated.
std::string inflated(std::string bytes, uint64_t max_bytes) {
  if (bytes.compare(0, kDeflatedTagSize, kDeflatedTag) != 0) return bytes;
  uint64_t n = 0;
  if (bytes.size() < kDeflatedTagSize + 8) return {};
  std::memcpy(&n, bytes.data() + kDeflatedTagSize, 8);
  if (n > max_bytes) return {};
  std::string out(n, '\0');
  uLongf size = n;
  const auto* src = reinterpret_cast<const Bytef*>(bytes.data() + kDeflatedTagSize + 8);
  if (uncompress(reinterpret_cast<Bytef*>(out.data()), &size, src, bytes.size() - kDeflatedTagSize - 8) != Z_OK ||
      size != n)
    return {};
  return shuffled(out, true);
}

// The bytes of the file at `path` into `out`, read at once into a string of the file's size (a
// stream copy grows its buffer by doubling: on a lung-sized entry of 150 MB that would be a
// third of the load). False if there is no such file; a file larger than `max_bytes` (more than any
// entry for this grid) is read as empty, so that it does not fit.
bool read_entry(const std::string& path, uint64_t max_bytes, std::string& out) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  out.clear();
  if (std::fseek(f, 0, SEEK_END) == 0) {
    const long size = std::ftell(f);
    if (size > 0 && uint64_t(size) <= max_bytes && std::fseek(f, 0, SEEK_SET) == 0) {
      out.resize(size_t(size));
      if (std::fread(out.data(), 1, out.size(), f) != out.size()) out.clear();
    }
  }
  std::fclose(f);
  return true;
}

}  // namespace

template <int D>
std::string field_cache_key(const Image<D>& image, const std::string& type, const std::string& parameters) {
  Hash128 h;
  // The generation tag changes whenever a field's numerics change (2: the GVF solvers' padded
  // kernels and fused multigrid passes, last bits; 3: single-precision vectors, GVF's fields
  // solved one after another; 4: W-cycles in the multigrid preconditioner), so that a cache
  // never serves a field that this build would not compute bit for bit.
  const std::string head = "dsnake-field-cache-4 D=" + std::to_string(D) + " type=" + type + " " + parameters;
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
CachedField<D>::CachedField(std::unique_ptr<ExternalField<D>> field, std::string dir, std::string parameters,
                            bool compressed)
    : field_(std::move(field)), large_(as_large(*field_)), dir_(std::move(dir)), parameters_(std::move(parameters)),
      compressed_(compressed) {}

template <int D>
std::string CachedField<D>::save_state() const {
  const CacheableField<D>* cacheable = as_cacheable(*field_);
  return cacheable != nullptr ? cacheable->save_state() : std::string();
}

template <int D>
bool CachedField<D>::load_state(const Grid<D>& grid, const std::string& bytes) {
  CacheableField<D>* cacheable = as_cacheable(*field_);
  return cacheable != nullptr && cacheable->load_state(grid, bytes);
}

// The entry for this image and these parameters (path_), loaded into the field if it is there
// and fits.
template <int D>
bool CachedField<D>::load_entry(const Image<D>& image) {
  loaded_ = false;
  path_ = (std::filesystem::path(dir_) / (field_->type() + "-" + field_cache_key(image, field_->type(), parameters_) +
                                          ".field"))
              .string();
  // No field stores more than 64 bytes a voxel (DDGVF: 2 D floats and D vector floats).
  const uint64_t max_bytes = uint64_t(image.num_voxels()) * 64 + (uint64_t(1) << 20);
  std::string bytes;
  if (!read_entry(path_, max_bytes, bytes)) return false;
  if (load_state(image.grid(), inflated(std::move(bytes), max_bytes))) return loaded_ = true;
  std::fprintf(stderr, "warning: field cache entry %s does not fit; recomputing\n", path_.c_str());
  return false;
}

// The computed field into the entry at path_ (a field that cannot be cached stores nothing).
template <int D>
void CachedField<D>::store_entry() const {
  const std::string state = save_state();
  if (state.empty()) return;
  try {
    std::filesystem::create_directories(dir_);
    write_file_atomically(path_, compressed_ ? deflated(state) : state);
  } catch (const std::exception& e) {  // a cache that cannot be written only costs time
    std::fprintf(stderr, "warning: cannot store the field in the cache: %s\n", e.what());
  }
}

template <int D>
void CachedField<D>::compute(const Image<D>& image) {
  if (load_entry(image)) return;
  field_->compute(image);
  store_entry();
}

// The key is read from the image first; on a miss the wrapped field may release the image as it
// computes (as without a cache).
template <int D>
void CachedField<D>::compute_releasing(Image<D>&& image) {
  if (load_entry(image)) return;
  dsnake::compute_releasing(*field_, std::move(image));
  store_entry();
}

template class CachedField<2>;
template class CachedField<3>;
template std::string field_cache_key(const Image<2>&, const std::string&, const std::string&);
template std::string field_cache_key(const Image<3>&, const std::string&, const std::string&);

}  // namespace dsnake
