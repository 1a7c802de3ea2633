// glibc malloc settings the dsnake executable makes at start-up, for the whole process's cost.
#pragma once

#include <cstddef>

namespace dsnake {

// The thresholds configure_heap sets: blocks from this size on are mmap'd, and the heap's free
// top is given back to the system only above the trim threshold.
constexpr std::size_t kHeapMmapThreshold = std::size_t(4) << 20;
constexpr std::size_t kHeapTrimThreshold = std::size_t(32) << 20;

// Sets glibc's mmap threshold to kHeapMmapThreshold and its trim threshold to
// kHeapTrimThreshold, except a threshold that `tunables` (the value of GLIBC_TUNABLES, or
// nullptr) sets itself, which the user chose.
//  - mmap threshold: volume-sized buffers go back to the system when freed. glibc serves a block
//    above its mmap threshold with mmap and unmaps it on free, but after such a free it raises the
//    threshold to that block's size (up to 32 MB), so that later volume-sized buffers (a float
//    array of a 230 x 300 x 80 volume is 22 MB) come from the heap, where a freed block below
//    the top stays resident: `dsnake field` peaked 52 MB of resident memory above its peak heap.
//    A fixed threshold (which also turns the dynamic one off) keeps every such buffer mmap'd, on
//    huge pages (glibc.malloc.hugetlb=1, set by main); smaller blocks, such as a mesh's arrays,
//    still come from the heap.
//  - trim threshold: turning the dynamic thresholds off leaves glibc's 128 kB, so the heap's
//    free top would go back to the system whenever it passed that. A remeshed mesh's arrays of a
//    few MB each are freed and allocated again at every remeshing, and each time the heap shrank
//    and grew back its pages would be faulted and cleared again (the real liver's recipe run,
//    27 000 vertices: 157 000-161 000 minor faults at 128 kB against 55 000-58 000 at 32 MB,
//    system time 2.5-3.1 against 1.8-2.3 s, the same peak of 1.14 GB). At most 32 MB of free
//    heap stays resident.
void configure_heap(const char* tunables);

}  // namespace dsnake
