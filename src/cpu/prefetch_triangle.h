// cpu/prefetch_triangle.h: requesting a triangle's vertices ahead of its test.
#pragma once

#include "irgrid/kernel/triangle.h"

namespace irgrid {

/// Requests both cache lines that `triangle`'s 36 bytes may lie on. In an array aligned to
/// 64 bytes, half of the triangles straddle two lines, and a test reads all nine coordinates:
/// requesting the first line alone left the second to a demand miss on scenes larger than the
/// caches (docs/benchmarks.md, "both lines of a triangle").
inline void prefetch_triangle(const TriangleVertices* triangle) {
  __builtin_prefetch(triangle);
  __builtin_prefetch(reinterpret_cast<const char*>(triangle) + sizeof(TriangleVertices) - 1);
}

}  // namespace irgrid
