#pragma once
// Large arrays on 2 MiB pages. A level of a million particles walks about 300 MB per step, which 4 KiB
// pages cover with 75,000 TLB entries' worth: on such a level the integration took 6.3-7.3 instead of
// 4.8-5.0 ns per particle-step and the forces up to 10 % longer (docs/performance.md). Linux backs
// memory with transparent huge pages only where the process asks (madvise) on most distributions, so
// dem_level asks for blocks of at least kHugeBlockBytes: its replacement of operator new
// (dem_level/huge_pages.cpp) aligns them to 2 MiB and marks them. The results do not change; only where
// the bytes live.
#include <cstddef>
#include <string>

namespace mlcg {

inline constexpr size_t kHugePageBytes = size_t{2} << 20;
inline constexpr size_t kHugeBlockBytes = size_t{1} << 20;

// The host's setting: the bracketed word of /sys/kernel/mm/transparent_hugepage/enabled ("always",
// "madvise", "never"), "" without the file (no transparent huge pages in this kernel).
std::string transparent_huge_pages_setting();
// Reads the host's setting (/sys/kernel/mm/transparent_hugepage/enabled) and, where it honours the
// request, turns it on for the rest of the process; MLCG_HUGE_PAGES=0 in the environment keeps 4 KiB
// pages (a 2 MiB page is resident as a whole once touched: a run's peak memory grows, by 14 % on the
// 1 M bench bed). Returns what the log and the summary say.
std::string enable_huge_pages();
// True once enable_huge_pages() found the host honours the request.
bool huge_pages_requested();
// What enable_huge_pages() found, for the summary ("" before it ran: a program that never asks).
const std::string& huge_pages_state();

}  // namespace mlcg
