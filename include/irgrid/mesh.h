// irgrid/mesh.h: the triangle mesh a caller hands to the library, in the caller's own arrays.
#pragma once

#include <cstddef>
#include <cstdint>

namespace irgrid {

/// An indexed triangle mesh held in the caller's arrays. The library reads it during
/// make_accelerator and Accelerator::rebuild and copies what it keeps (every structure stores
/// its own copy of the triangles' vertices), so the arrays may be freed or changed as soon as
/// those calls return. Triangle i (and Hit::prim == i) is indices[3i], indices[3i+1],
/// indices[3i+2].
struct TriangleMesh {
  /// x, y, z of vertex 0 as float32; vertex k starts vertex_stride bytes after vertex k-1.
  const float* vertices = nullptr;
  std::size_t vertex_count = 0;
  /// Bytes from one vertex to the next: 12 for packed float3, 16 for float4 padding, or any
  /// multiple of 4 that is at least 12 (a position inside a larger vertex record).
  std::size_t vertex_stride = 3 * sizeof(float);
  /// Three vertex indices per triangle.
  const std::uint32_t* indices = nullptr;
  std::size_t triangle_count = 0;

  /// The position of vertex k.
  const float* vertex(std::size_t k) const {
    return reinterpret_cast<const float*>(reinterpret_cast<const char*>(vertices) +
                                          k * vertex_stride);
  }
};

/// Throws Error{invalid_argument} naming the problem for a mesh no structure can take: a null
/// array with a non-zero count, a stride below 12 or not a multiple of 4, a vertex index out of
/// range, or a vertex with a NaN or infinite coordinate used by a triangle (the first such
/// triangle is named); Error{limit_exceeded} past 2^32 - 1 triangles or vertices, the range of
/// the 32-bit ids, for a coordinate beyond 2^60 (1.15e18) in magnitude, or for triangles that
/// span less than 2^-40 (9.1e-13) along every axis (the float range of the watertight test,
/// docs/robustness.md). Zero-area triangles are valid: no ray hits them. make_accelerator and
/// rebuild call it.
void check_mesh(const TriangleMesh& mesh);

}  // namespace irgrid
