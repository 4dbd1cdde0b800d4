#pragma once
// STL reader (ASCII and binary) for mesh walls.
//
// Format detection: a file is binary when its size equals 84 + 50 * n, with n
// the little-endian triangle count at byte 80, even if it begins with "solid"
// (many exporters write "solid" into the binary header). Otherwise a file that
// begins with "solid" and holds no NUL byte is ASCII; anything else is binary
// (and then too short for its declared count -> truncation error).
//
// Errors are std::runtime_error with messages of the form
//   "<path>:<line>: expected 'vertex x y z', found 'vertx 1 2'"          (ASCII)
//   "<path>: truncated binary STL: 12 triangles need 684 bytes, found 674" (binary)
// A file with no triangles is an error. Facet normals in the file are ignored:
// the orientation of a triangle is the right-hand rule of its vertex order.
#include <string>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg {

struct RawTriangle {
  Vec3 a, b, c;
};

std::vector<RawTriangle> read_stl(const std::string& path);

// Writers, used by tests and tools to produce fixtures. Facet normals are
// written from the vertex order. Throw std::runtime_error on I/O failure.
void write_stl_ascii(const std::string& path, const std::vector<RawTriangle>& tris,
                     const std::string& solid_name = "mesh");
// `header` fills the 80-byte header (truncated / zero padded); it may start with "solid".
void write_stl_binary(const std::string& path, const std::vector<RawTriangle>& tris,
                      const std::string& header = "binary STL written by mlcg");

}  // namespace mlcg
