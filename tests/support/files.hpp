#pragma once
// Files and temporary folders for the tests: one way to read a file whole, one naming of a test's
// temporary paths (so that runs of different test processes never meet), one folder that cleans up
// after itself.
#include <filesystem>
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace mlcg::test {

// The bytes of `p` as they are (no newline translation); "" when it is missing or unreadable, so a
// test that expected content fails on its own assertion rather than here.
std::string slurp(const std::filesystem::path& p);

// `p` parsed as JSON; throws nlohmann::json::parse_error when it is missing or not JSON.
nlohmann::json read_json(const std::filesystem::path& p);

// A path in the temporary folder that only this test process uses: mlcg_<tag>_<pid>. Nothing is made
// or removed: the caller (or the program under test) makes it.
std::filesystem::path temp_path(const std::string& tag);

// temp_path(tag) with whatever an earlier test process of the same pid left there removed; not made,
// for the programs that refuse a folder that already exists.
std::filesystem::path fresh_temp_path(const std::string& tag);

// A folder at temp_path(tag), empty when made. It is removed with everything in it at destruction,
// unless the running test has failed: then it is kept (and named on stderr) for a look at what the
// test left.
class TempDir {
 public:
  explicit TempDir(const std::string& tag);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return dir_; }
  std::filesystem::path operator/(const std::filesystem::path& name) const { return dir_ / name; }

 private:
  std::filesystem::path dir_;
};

}  // namespace mlcg::test
