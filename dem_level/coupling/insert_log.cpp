#include "coupling/insert_log.hpp"

#include <string>

#include <fmt/format.h>

#include "core/spheres.hpp"
#include "io/atomic_file.hpp"

namespace mlcg::coupling {
namespace {
constexpr const char* kHeader = "interval,grid,face,id,x,y,z,radius,mass\n";
}  // namespace

void InsertLog::open(const std::filesystem::path& path, uint64_t start) {
  std::string kept = kHeader;
  if (start > 0) {  // the rows of the intervals before the checkpoint's; the file of an earlier attempt
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line))
      if (std::stoull(line.substr(0, line.find(','))) < start) kept += line + "\n";
  }
  io::write_file_atomic(path, kept);
  out_.open(path, std::ios::app);
}

void InsertLog::record(uint64_t k, const bus::GridCommands& c, const std::vector<ParticleInit>& list) {
  if (!out_.is_open()) return;
  for (size_t j = 0; j < list.size(); ++j) {
    const ParticleInit& p = list[j];
    const int face = static_cast<int>(j) < c.insert_face_size() ? c.insert_face(static_cast<int>(j)) : -1;
    out_ << fmt::format("{},{},{},{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", k, c.grid(), face, p.id, p.x.x,
                        p.x.y, p.x.z, p.radius, sphere_mass(p.density, p.radius));
  }
}

}  // namespace mlcg::coupling
