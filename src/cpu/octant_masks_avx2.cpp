// cpu/octant_masks_avx2.cpp: child_overlap_masks (cpu/octant_masks.h) in the 8 lanes of AVX2.
// Only the code below the pragma is compiled for avx2, and it runs only where cpu_has() says
// the CPU has it; the headers it uses are included above the pragma, so that their inline
// functions stay baseline code.
#include <immintrin.h>

#include <cstdint>

#include "core/construction/octree_levels.h"
#include "core/triangle_box.h"
#include "cpu/octant_masks.h"
#include "irgrid/kernel/triangle.h"

#pragma GCC push_options
#pragma GCC target("avx2")
#pragma GCC diagnostic ignored "-Wpsabi"

#include "cpu/octant_masks_lanes.h"
#include "cpu/simd_lanes_avx2.h"

namespace irgrid {

template <>
void child_overlap_masks_in_lanes<SimdIsa::avx2>(const NodeSplit& node,
                                                 const TriangleVertices* triangles,
                                                 const std::uint32_t* ids, std::uint32_t count,
                                                 std::uint8_t* masks) {
  simd::OctantMaskLanes<simd::Avx2Lanes>::child_overlap_masks(node, triangles, ids, count, masks);
}

}  // namespace irgrid

#pragma GCC pop_options
