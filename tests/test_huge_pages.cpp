// dem_level's operator new (dem_level/huge_pages.cpp, linked into this test as into dem_level): once
// enable_huge_pages() found the host honours transparent huge pages, a block of 1 MiB or more starts on
// a 2 MiB boundary and the kernel backs it with 2 MiB pages (read back from /proc/self/smaps, the
// kernel's own account, not from what the allocator meant to do).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/huge_pages.hpp"

namespace {

// The kB of 2 MiB pages backing the mapping that holds address a (-1 when no mapping holds it).
long anon_huge_kb_at(uintptr_t a) {
  std::ifstream in("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    unsigned long lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-' && line.find(':') > line.find(' ')) {
      inside = a >= lo && a < hi;
      continue;
    }
    if (inside && line.rfind("AnonHugePages:", 0) == 0) return std::stol(line.substr(14));
  }
  return -1;
}

}  // namespace

TEST(HugePages, LargeBlocksStartOnA2MiBBoundaryAndAreBackedByHugePages) {
  const std::string state = mlcg::enable_huge_pages();
  const std::string host = mlcg::transparent_huge_pages_setting();
  if (host != "madvise" && host != "always") {
    // A host that refuses: the state says so, and blocks still come (on small pages).
    EXPECT_NE(state.find("4 KiB"), std::string::npos) << state;
    std::vector<double> v(1 << 20, 1.0);
    EXPECT_EQ(v[123], 1.0);
    return;
  }
  EXPECT_TRUE(mlcg::huge_pages_requested());
  EXPECT_NE(state.find("2 MiB"), std::string::npos) << state;
  std::vector<double> big(3 << 17, 1.0);  // 3 MiB, every page touched
  const auto a = reinterpret_cast<uintptr_t>(big.data());
  EXPECT_EQ(a % mlcg::kHugePageBytes, 0u);
  // Both of its 2 MiB pages, the last one only partly used.
  EXPECT_GE(anon_huge_kb_at(a), 4096) << "the kernel backs (part of) the block with 4 KiB pages";
}

TEST(HugePages, TheEnvironmentsMlcgHugePages0KeepsSmallPages) {
  setenv("MLCG_HUGE_PAGES", "0", 1);
  const std::string state = mlcg::enable_huge_pages();
  unsetenv("MLCG_HUGE_PAGES");
  EXPECT_FALSE(mlcg::huge_pages_requested());
  EXPECT_EQ(state, "4 KiB pages (MLCG_HUGE_PAGES=0)");
}

TEST(HugePages, SmallBlocksKeepTheirOwnPlace) {
  mlcg::enable_huge_pages();
  // Blocks below 1 MiB stay with malloc: two of them are not both on 2 MiB boundaries.
  std::vector<double> a(1000), b(1000);
  const auto pa = reinterpret_cast<uintptr_t>(a.data()), pb = reinterpret_cast<uintptr_t>(b.data());
  EXPECT_FALSE(pa % mlcg::kHugePageBytes == 0 && pb % mlcg::kHugePageBytes == 0);
}
