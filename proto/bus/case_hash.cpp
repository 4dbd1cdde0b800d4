#include "bus/case_hash.hpp"

#include <cstdint>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <fmt/format.h>

namespace mlcg::bus {

std::string case_hash_of_bytes(std::string_view bytes) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return fmt::format("{:016x}", h);
}

std::string case_hash(const std::filesystem::path& case_file) {
  std::ifstream in(case_file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read case file " + case_file.string());
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return case_hash_of_bytes(bytes);
}

}  // namespace mlcg::bus
