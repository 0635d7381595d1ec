// python/src/arrays.h: numpy rays to irgrid rays, hits to the arrays Python returns.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "irgrid/ray.h"

namespace irgrid::python {

/// Rays from n rows of 6 floats (origin, direction), ray i over [tmin[i], tmax[i]].
std::vector<Ray> rays_from_rows(const float* rows, std::size_t n, const float* tmin,
                                const float* tmax);

/// The hits as Python returns them: t (inf on a miss), primitive id (kNoHit on a miss), u, v
/// and the unit geometric normal of the triangle hit (zero on a miss), from the mesh's
/// float32 xyz vertices and uint32 triangles.
void split_hits(std::span<const Hit> hits, const float* vertices, const std::uint32_t* triangles,
                float* t, std::uint32_t* prim, float* uv, float* normals);

}  // namespace irgrid::python
