// cpu/triangle_planes.cpp: which lanes triangle_planes_of runs in. Compiled for the baseline
// target; the lanes live in build_lanes_avx2.cpp and build_lanes_avx512.cpp.
#include "cpu/triangle_planes.h"

#include <cstdint>

#include "core/construction/expand_face.h"

namespace irgrid {

void triangle_planes_of(const GridInfo& info, const TriangleVertices* triangles,
                        std::uint32_t count, expand_detail::TrianglePlanes* out) {
  // The lanes gather within one register's triangles: no index limit.
  if (count >= 4) {
    if (cpu_has(SimdIsa::avx512))
      return triangle_planes_in_lanes<SimdIsa::avx512>(info, triangles, count, out);
    if (cpu_has(SimdIsa::avx2))
      return triangle_planes_in_lanes<SimdIsa::avx2>(info, triangles, count, out);
  }
  for (std::uint32_t k = 0; k < count; ++k)
    out[k] = expand_detail::triangle_planes(info, expand_detail::TriangleBounds{triangles[k]});
}

}  // namespace irgrid
