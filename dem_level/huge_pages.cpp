// dem_level's operator new: blocks of kHugeBlockBytes and more, once enable_huge_pages() found the host
// honours it, start on a 2 MiB boundary and are marked for transparent huge pages (core/huge_pages.hpp).
// Linked into the dem_level programs only; every other program and test keeps the library's allocator.
// Everything is freed by free(), which takes both kinds.
#include <sys/mman.h>

#include <cstdlib>
#include <new>

#include "core/huge_pages.hpp"

namespace {

// A large block is rounded up to whole 2 MiB pages (at most 2 MiB more per block), so that its last page is
// one too; the kernel backs only a whole aligned 2 MiB range marked as a huge page.
void* allocate(std::size_t n) {
  if (n >= mlcg::kHugeBlockBytes && mlcg::huge_pages_requested()) {
    const std::size_t whole = (n + mlcg::kHugePageBytes - 1) & ~(mlcg::kHugePageBytes - 1);
    if (void* p = std::aligned_alloc(mlcg::kHugePageBytes, whole)) {
      madvise(p, whole, MADV_HUGEPAGE);  // advice only: where the kernel declines, the pages stay small
      return p;
    }
  }
  return std::malloc(n == 0 ? 1 : n);
}

}  // namespace

void* operator new(std::size_t n) {
  if (void* p = allocate(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  if (void* p = allocate(n)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return allocate(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return allocate(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
