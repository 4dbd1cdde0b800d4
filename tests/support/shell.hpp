#pragma once
// Shell commands from a test: the programs under test are started the way a user starts them.
#include <string>

namespace mlcg::test {

// `cmd` run by /bin/sh; its exit code, or -1 when it did not exit (killed by a signal).
int run(const std::string& cmd);

// The same with its stdout and stderr caught in `out` (through a file in the temporary folder, removed after).
int run(const std::string& cmd, std::string& out);

}  // namespace mlcg::test
