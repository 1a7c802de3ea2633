// configure_heap (experiments/cli/heap_settings.h): glibc's thresholds as the dsnake executable sets
// them (process-wide: each test sets what it relies on, so that the order does not matter). Not run under AddressSanitizer (scripts/test_sanitize.sh): its allocator replaces
// glibc's malloc, whose settings these are.
#include "experiments/cli/heap_settings.h"

#include <gtest/gtest.h>
#include <malloc.h>

#include <cstdlib>
#include <cstring>
#include <vector>

namespace dsnake {
namespace {

// glibc serves a request from the heap's free top when it holds it, whatever the mmap threshold:
// each test starts from a trimmed heap, so that its requests reach the thresholds.
void start_from_a_trimmed_heap() { malloc_trim(0); }

// Touches every page of a block, as a buffer that is filled would.
void touch(void* p, std::size_t bytes) { std::memset(p, 1, bytes); }

// `count` blocks of `bytes` in a row, each touched, then freed from the last to the first.
void allocate_touch_and_free(int count, std::size_t bytes) {
  std::vector<void*> blocks(count);
  for (void*& p : blocks) {
    p = std::malloc(bytes);
    ASSERT_NE(p, nullptr);
    touch(p, bytes);
  }
  for (int i = count - 1; i >= 0; --i) std::free(blocks[i]);
}

TEST(HeapSettings, BlocksFromFourMegabytesOnAreMappedAndSmallerOnesComeFromTheHeap) {
  configure_heap(nullptr);
  start_from_a_trimmed_heap();
  // glibc's dynamic threshold would start at 128 kB and serve a 3 MB block with mmap.
  const std::size_t small = 3u << 20, large = kHeapMmapThreshold + (1u << 20);
  const size_t mapped_before = mallinfo2().hblkhd;
  void* a = std::malloc(small);
  ASSERT_NE(a, nullptr);
  touch(a, small);
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before) << "a 3 MB block is mmap'd";
  void* b = std::malloc(large);
  ASSERT_NE(b, nullptr);
  touch(b, large);
  EXPECT_GE(mallinfo2().hblkhd, mapped_before + large) << "a 5 MB block is not mmap'd";
  std::free(b);
  // Freeing a mapped block must not raise the threshold (the dynamic rule is off): the next
  // block of that size is mapped again.
  void* c = std::malloc(large);
  ASSERT_NE(c, nullptr);
  EXPECT_GE(mallinfo2().hblkhd, mapped_before + large) << "the threshold moved after a free";
  std::free(c);
  std::free(a);
}

TEST(HeapSettings, AFreedHeapTopBelowThirtyTwoMegabytesStaysResident) {
  configure_heap(nullptr);
  start_from_a_trimmed_heap();
  // Three 3 MB blocks in a row, freed: they merge with the heap's top, which glibc's 128 kB trim
  // threshold would give back to the system at once (its next growth then faults every page again).
  const std::size_t bytes = 3u << 20;
  allocate_touch_and_free(3, bytes);
  EXPECT_GE(mallinfo2().keepcost, 3 * bytes) << "the heap's free top was trimmed";
  // Above the threshold the top is still trimmed: the resident free heap stays bounded.
  allocate_touch_and_free(16, bytes);
  EXPECT_LE(mallinfo2().keepcost, kHeapTrimThreshold + (1u << 20)) << "more than the trim threshold kept";
}

TEST(HeapSettings, ThresholdsTheUserSetAreKept) {
  // GLIBC_TUNABLES naming both thresholds: configure_heap leaves both alone, so the thresholds
  // as they were (here glibc's starting values, set explicitly: an earlier test in the same
  // process may have changed them) still serve a 3 MB block with mmap.
  mallopt(M_MMAP_THRESHOLD, 128 * 1024);
  mallopt(M_TRIM_THRESHOLD, 128 * 1024);
  configure_heap("glibc.malloc.mmap_threshold=131072:glibc.malloc.trim_threshold=131072");
  start_from_a_trimmed_heap();
  const std::size_t small = 3u << 20;
  const size_t mapped_before = mallinfo2().hblkhd;
  void* a = std::malloc(small);
  ASSERT_NE(a, nullptr);
  EXPECT_GE(mallinfo2().hblkhd, mapped_before + small);
  std::free(a);
}

}  // namespace
}  // namespace dsnake
