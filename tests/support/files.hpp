#pragma once
// Files and temporary folders for the tests: one way to read a file whole, one naming of a test's
// temporary paths (so that runs of different test processes never meet), one folder that cleans up
// after itself.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

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

// One text edit: the first occurrence of `from` becomes `to`.
using Edit = std::pair<std::string, std::string>;

// The case file `src` copied into the folder `dir` (made if missing) together with its chain of bases
// (`base = "..."`, cases/README.md "Variants"), each under its own file name, with every edit applied to
// the first file of the chain that holds its `from`: the case itself, then its base, and so on. An edit
// no file holds fails the test. Returns the copy of `src`. Relative mesh or [initial] files of the case
// are not copied (the shipped variant scenes have none).
std::filesystem::path copy_case(const std::filesystem::path& src, const std::filesystem::path& dir,
                                const std::vector<Edit>& edits = {});

// Removes the folder copy_case made for `copy` (the case's copy and its bases). A copy straight in the
// temporary folder fails the test instead: that folder is everyone's.
void remove_case_copy(const std::filesystem::path& copy);

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
