// cpu/triangle_planes.h: the expansion's per-triangle voxel planes, many triangles at once.
//
// Partial expansion settles a neighbour's extra triangles from their TrianglePlanes
// (core/construction/expand_face.h), made once per triangle before the expansion: twelve
// thresholds, each a rounded guess stepped while a float comparison says otherwise, about 45 ns
// of scalar work per triangle (Sponza's 279 K triangles took 12-13 ms on one thread). Here one
// lane holds one triangle, 16 with AVX-512 and 8 with AVX2, and the steps run lane-wise until
// every lane has settled. Every lane repeats triangle_planes' float operations in the same
// order, so the planes are the same (tests/test_grid_expand.cpp).
#pragma once

#include <cstdint>

#include "cpu/simd_walk.h"

namespace irgrid {

struct GridInfo;
struct TriangleVertices;
namespace expand_detail {
struct TrianglePlanes;
}

/// out[k] = triangle_planes(info, TriangleBounds{triangles[k]}) for k < count, in the widest
/// SIMD lanes this CPU runs, one triangle at a time without them. Requires
/// fits_compact_cells(info), as triangle_planes does.
void triangle_planes_of(const GridInfo& info, const TriangleVertices* triangles,
                        std::uint32_t count, expand_detail::TrianglePlanes* out);

/// triangle_planes_of in the lanes of kIsa. Requires cpu_has(kIsa).
template <SimdIsa kIsa>
void triangle_planes_in_lanes(const GridInfo& info, const TriangleVertices* triangles,
                              std::uint32_t count, expand_detail::TrianglePlanes* out);

}  // namespace irgrid
