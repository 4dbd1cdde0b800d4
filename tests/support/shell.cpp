#include "shell.hpp"

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>

#include "files.hpp"

namespace mlcg::test {

int run(const std::string& cmd) {
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

int run(const std::string& cmd, std::string& out) {
  const std::filesystem::path log = temp_path("run_out");
  const int rc = run(cmd + " > " + log.string() + " 2>&1");
  out = slurp(log);
  std::filesystem::remove(log);
  return rc;
}

}  // namespace mlcg::test
