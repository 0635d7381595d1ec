// python/src/hit_split.h: one hit as Python returns it, for the device kernel of rays in GPU
// arrays (device_kernels.cu); host rays get theirs from the library's trace into HitArrays.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "irgrid/kernel/platform.h"
#include "irgrid/ray.h"

namespace irgrid::python {

/// Writes hit `h` of ray i into element i of t (inf on a miss), prim (kNoHit on a miss), uv
/// (2 per ray) and normals (3 per ray: the triangle's from `triangle_normals`, zero on a miss).
IRGRID_HD inline void split_hit(std::size_t i, const Hit& h, const float* triangle_normals,
                                float* t, std::uint32_t* prim, float* uv, float* normals) {
  prim[i] = h.prim;
  float* normal = normals + 3 * i;
  if (h.prim == kNoHit) {
    t[i] = INFINITY;
    uv[2 * i] = uv[2 * i + 1] = 0;
    normal[0] = normal[1] = normal[2] = 0;
    return;
  }
  t[i] = h.t, uv[2 * i] = h.u, uv[2 * i + 1] = h.v;
  const float* source = triangle_normals + 3 * std::size_t(h.prim);
  normal[0] = source[0], normal[1] = source[1], normal[2] = source[2];
}

}  // namespace irgrid::python
