#include "files.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <regex>
#include <system_error>

#include <nlohmann/json.hpp>

namespace fs = std::filesystem;

namespace mlcg::test {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

fs::path temp_path(const std::string& tag) {
  return fs::temp_directory_path() / ("mlcg_" + tag + "_" + std::to_string(::getpid()));
}

fs::path fresh_temp_path(const std::string& tag) {
  const fs::path p = temp_path(tag);
  fs::remove_all(p);
  return p;
}

fs::path copy_case(const fs::path& src, const fs::path& dir, const std::vector<Edit>& edits) {
  static const std::regex base_line(R"re((^|\n)base\s*=\s*"([^"]+)")re");
  std::vector<std::pair<fs::path, std::string>> chain;  // (copy, text), the case first
  for (fs::path from = src; !from.empty();) {
    std::string text = slurp(from);
    EXPECT_FALSE(text.empty()) << "cannot read " << from;
    fs::path next;
    std::smatch m;
    if (std::regex_search(text, m, base_line)) {
      next = (from.parent_path() / m[2].str()).lexically_normal();
      text.replace(static_cast<size_t>(m.position(2)), m[2].length(), next.filename().string());
    }
    chain.emplace_back(dir / from.filename(), std::move(text));
    if (chain.size() > 16) break;
    from = next;
  }
  for (const auto& [from, to] : edits) {
    bool done = false;
    for (auto& link : chain) {
      const size_t at = link.second.find(from);
      if (at == std::string::npos) continue;
      link.second.replace(at, from.size(), to);
      done = true;
      break;
    }
    EXPECT_TRUE(done) << "neither " << src << " nor its bases hold: " << from;
  }
  fs::create_directories(dir);
  for (const auto& [path, text] : chain) std::ofstream(path, std::ios::binary) << text;
  return chain.front().first;
}

void remove_case_copy(const fs::path& copy) {
  const fs::path dir = fs::absolute(copy).parent_path();
  std::error_code ec;
  if (dir.empty() || fs::equivalent(dir, fs::temp_directory_path(), ec) || dir == dir.root_path()) {
    ADD_FAILURE() << copy << " is not in a folder of its own: not removing " << dir;
    return;
  }
  fs::remove_all(dir, ec);
}

TempDir::TempDir(const std::string& tag) : dir_(fresh_temp_path(tag)) { fs::create_directories(dir_); }

TempDir::~TempDir() {
  if (::testing::Test::HasFailure()) {
    std::fprintf(stderr, "kept for a look: %s\n", dir_.c_str());
    return;
  }
  std::error_code ec;  // a destructor must not throw; a folder left behind is harmless
  fs::remove_all(dir_, ec);
}

}  // namespace mlcg::test
