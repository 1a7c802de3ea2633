// What this machine charges, at this moment, for memory a process touches for the first time.
// Not a benchmark of dsnake: a probe that
// experiments/bench/whole_process.sh prints beside the whole-process figures, which it explains.
//
// A run's volumes are fresh mappings, and their first touch pays a page fault and the clearing
// of the page. On a virtual machine whose free memory goes back to the host (free page
// reporting), that also pays the host for backing the page again, and this part depends on the
// host's state, not on the process: the same binary's lung run, whose peak is 320 MB, varied by
// more than a second within the same half hour. Memory freed and mapped again within the same
// process a moment later is still backed, and costs only the clearing.
//
// Usage: first_touch [MB]   (default 320, the lung run's peak). Prints, for MB of anonymous
// memory on transparent huge pages where the system gives them (madvise), one write per 4 kB
// page: the seconds of the first touch, and of a second touch of a new mapping made right after
// the first was unmapped.
#include <sys/mman.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace {

// Maps `bytes`, writes one byte per 4 kB page, unmaps; the seconds from the map to the last write.
double touch_fresh(std::size_t bytes) {
  const auto start = std::chrono::steady_clock::now();
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) {
    std::fprintf(stderr, "first_touch: cannot map %zu bytes\n", bytes);
    std::exit(2);
  }
  madvise(p, bytes, MADV_HUGEPAGE);
  volatile char* c = static_cast<char*>(p);
  for (std::size_t i = 0; i < bytes; i += 4096) c[i] = 1;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  munmap(p, bytes);
  return seconds;
}

}  // namespace

int main(int argc, char** argv) {
  const long mb = argc > 1 ? std::strtol(argv[1], nullptr, 10) : 320;
  if (mb <= 0 || mb > (1 << 20)) {
    std::fprintf(stderr, "first_touch: MB must be a positive number of megabytes, got '%s'\n", argv[1]);
    return 2;
  }
  const std::size_t bytes = std::size_t(mb) << 20;
  const double fresh = touch_fresh(bytes);
  const double again = touch_fresh(bytes);
  std::printf("%ld MB: first touch %.3f s (%.2f s/GB), again right after %.3f s (%.2f s/GB)\n", mb, fresh,
              fresh * 1024 / mb, again, again * 1024 / mb);
  return 0;
}
