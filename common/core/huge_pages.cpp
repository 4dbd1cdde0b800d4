#include "core/huge_pages.hpp"

#include <cstdlib>
#include <fstream>

namespace mlcg {

namespace {
bool g_requested = false;
std::string g_state;
}  // namespace

std::string transparent_huge_pages_setting() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  if (!std::getline(in, line)) return "";
  const auto a = line.find('['), b = line.find(']');
  return a == std::string::npos || b == std::string::npos || b < a ? "" : line.substr(a + 1, b - a - 1);
}

std::string enable_huge_pages() {
  const char* env = std::getenv("MLCG_HUGE_PAGES");
  if (env && std::string(env) == "0") {
    g_requested = false;
    g_state = "4 KiB pages (MLCG_HUGE_PAGES=0)";
    return g_state;
  }
  const std::string s = transparent_huge_pages_setting();
  g_requested = s == "madvise" || s == "always";
  if (s == "always") g_state = "2 MiB pages (transparent huge pages: always)";
  else if (s == "madvise") g_state = "2 MiB pages for blocks of 1 MiB and more (transparent huge pages: madvise)";
  else if (s.empty()) g_state = "4 KiB pages (this kernel has no transparent huge pages)";
  else g_state = "4 KiB pages (transparent huge pages: " + s + " on this host)";
  return g_state;
}

bool huge_pages_requested() { return g_requested; }
const std::string& huge_pages_state() { return g_state; }

}  // namespace mlcg
