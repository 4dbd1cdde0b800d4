#pragma once
// A process that builds and parses messages of a few hundred kB every coupling interval (the
// insertion slabs' occupants) would otherwise take each buffer from fresh pages: glibc maps
// blocks above its mmap threshold one by one and trims the heap's top after each free, so every
// interval paid a page fault per 4 kB touched (18,000 a minute in the coupler of a wide region).
// Keeping freed memory in the heap reuses the same pages.
#include <malloc.h>

namespace mlcg {

inline void keep_freed_memory() {
  mallopt(M_MMAP_THRESHOLD, 64 << 20);  // blocks up to 64 MiB come from the heap
  mallopt(M_TRIM_THRESHOLD, 256 << 20);  // and the heap keeps up to 256 MiB free at its top
}

}  // namespace mlcg
