// Fuzz target: the STL reader (ASCII and binary) and the mesh wall built from its triangles, as a
// case's `type = "mesh"` wall is read. Seeds: every shipped .stl. Bad input must come back as a
// std::runtime_error naming the file (and line).
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "fuzz_support.hpp"
#include "walls/stl_reader.hpp"
#include "walls/triangle_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto file = mlcg::fuzz::scratch() / "mesh.stl";
  mlcg::fuzz::write_file(file, data, size);
  try {
    const mlcg::TriangleMesh mesh(mlcg::read_stl(file.string()), file.string());
  } catch (const std::runtime_error&) {
  }
  return 0;
}
