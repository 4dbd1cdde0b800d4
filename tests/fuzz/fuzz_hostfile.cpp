// Fuzz target: the hostfile of `mlcg run --hosts` (launcher::read_hostfile) and the placement of a
// three-level case's processes on its hosts (launcher::Placement). Seeds: the README's and the tests'
// hostfiles (fuzz_seeds). Bad input must come back as a HostError naming file and line.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "hosts/hosts.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto cs = mlcg::fuzz::shipped_case("cases/quickstart/mlcg3.toml");
  static const auto file = mlcg::fuzz::scratch() / "hostfile";
  mlcg::fuzz::write_file(file, data, size);
  try {
    const auto hf = mlcg::launcher::read_hostfile(file.string());
    const mlcg::launcher::Placement placement(hf, cs);
    placement.launch_prefix("coupler", 1);
    for (const auto& l : cs.levels) placement.launch_prefix(l.name, l.ranks);
    placement.describe();
  } catch (const mlcg::launcher::HostError&) {
  }
  return 0;
}
