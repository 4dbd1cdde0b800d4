#include "bus/checkpoint_file.hpp"

#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>

namespace mlcg::bus {

CouplerCheckpoint read_coupler_checkpoint(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.empty()) throw std::runtime_error(path.string() + " is empty (0 bytes)");
  CouplerCheckpoint c;
  // Every checkpoint the coupler writes names its case: a parse without one is a cut-short file.
  if (!c.ParseFromString(bytes) || c.case_hash().empty())
    throw std::runtime_error(path.string() + " is truncated or not a coupler checkpoint (" +
                             std::to_string(bytes.size()) + " bytes)");
  return c;
}

}  // namespace mlcg::bus
