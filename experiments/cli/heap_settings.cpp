#include "experiments/cli/heap_settings.h"

#include <malloc.h>

#include <cstring>

namespace dsnake {

void configure_heap(const char* tunables) {
  if (!(tunables && std::strstr(tunables, "mmap_threshold"))) mallopt(M_MMAP_THRESHOLD, int(kHeapMmapThreshold));
  if (!(tunables && std::strstr(tunables, "trim_threshold"))) mallopt(M_TRIM_THRESHOLD, int(kHeapTrimThreshold));
}

}  // namespace dsnake
