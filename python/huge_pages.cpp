// Large buffers on transparent huge pages in the Python module, as the dsnake executable has them.
//
// The executable starts itself with GLIBC_TUNABLES=glibc.malloc.hugetlb=1 (experiments/cli/main.cpp):
// glibc then advises huge pages (madvise MADV_HUGEPAGE) for every block it maps, which on a kernel
// whose transparent huge pages are "madvise" (Debian's default) is what puts a volume's images,
// fields and solver arrays on 2 MB pages. glibc reads that setting once, when a process starts,
// and python3 starts without it, so a volume's buffers would sit on 4 kB pages, with many more
// page faults and TLB misses in the field solve, the evolution and the metrics alike
// (docs/performance.md measures it). So the module replaces operator new for its own code: a block of
// kHeapMmapThreshold or more (the size from which glibc maps blocks, experiments/cli/heap_settings.h)
// gets the same advice before it is first touched.
//
// The memory still comes from malloc, so it is freed by free() as every operator delete of the
// process does: a block allocated here and freed by libstdc++, or the other way round, is fine.
// The module is linked with -Bsymbolic-functions, so these definitions serve the module's own
// calls and no other library of the process.
#include "experiments/cli/heap_settings.h"

#include <cstdint>
#include <cstdlib>
#include <new>
#include <sys/mman.h>

namespace {

constexpr std::uintptr_t kHugePage = std::uintptr_t(2) << 20;

// Advises huge pages for the whole 2 MB pages inside [p, p + n) (the advice is per page range; the
// block's unaligned ends stay on small pages, as glibc leaves them).
void advise_huge_pages(void* p, std::size_t n) {
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(p) + kHugePage - 1) & ~(kHugePage - 1);
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(p) + n) & ~(kHugePage - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // a hint: failure is harmless
}

void* allocate(std::size_t n) {
  void* p = std::malloc(n == 0 ? 1 : n);
  if (p == nullptr) throw std::bad_alloc();
  if (n >= dsnake::kHeapMmapThreshold) advise_huge_pages(p, n);
  return p;
}

}  // namespace

void* operator new(std::size_t n) { return allocate(n); }
void* operator new[](std::size_t n) { return allocate(n); }
