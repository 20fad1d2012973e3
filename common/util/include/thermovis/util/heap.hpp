#pragma once
// The heap policy of every thermovis process that handles images frame after frame (services
// and the command line's benches alike, so that a bench measures what the service does).
#include <malloc.h>

namespace thermovis::util {

// Per-frame images and buffers of tens of kB to a few MB are allocated and freed at up to
// 50 Hz. By default glibc maps and unmaps each block over 128 kB and returns the heap's free top
// to the system past 128 kB; every fresh page touched afterwards is a page fault, which on this
// kind of virtual machine costs more than the image processing itself (a frame of the obstacle
// stage measured 8 -> 19 ms of CPU when a few small allocations moved the heap's top). Keep
// such blocks on the heap for reuse instead.
inline void keep_freed_heap() {
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 256 * 1024 * 1024);
}

}  // namespace thermovis::util
