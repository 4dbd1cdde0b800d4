#include "files.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iterator>
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
