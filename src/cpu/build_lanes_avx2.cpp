// cpu/build_lanes_avx2.cpp: the build's steps in SIMD lanes, in the 8 lanes of AVX2: the octrees'
// children masks (cpu/octant_masks.h), a merge sweep's proposals (cpu/merge_propose.h) and the
// expansion's triangle planes (cpu/triangle_planes.h).
// Only the code below the pragma is compiled for avx2, and it runs only where cpu_has() says the
// CPU has it; the headers it uses are included above the pragma, so that their inline functions
// stay baseline code.
#include <immintrin.h>

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/construction/expand_face.h"
#include "core/construction/merge_lists.h"
#include "core/construction/merge_pairs.h"
#include "core/construction/narrow_cell.h"
#include "core/construction/octree_levels.h"
#include "core/triangle_box.h"
#include "cpu/merge_propose.h"
#include "cpu/octant_masks.h"
#include "cpu/triangle_planes.h"
#include "irgrid/kernel/grid_layout.h"
#include "irgrid/kernel/triangle.h"

#pragma GCC push_options
#pragma GCC target("avx2")
#pragma GCC diagnostic ignored "-Wpsabi"

#include "cpu/merge_propose_lanes.h"
#include "cpu/octant_masks_lanes.h"
#include "cpu/simd_lanes_avx2.h"
#include "cpu/triangle_planes_lanes.h"

namespace irgrid {

template <>
void child_overlap_masks_in_lanes<SimdIsa::avx2>(const NodeSplit& node,
                                                 const TriangleVertices* triangles,
                                                 const std::uint32_t* ids, std::uint32_t count,
                                                 std::uint8_t* masks) {
  simd::OctantMaskLanes<simd::Avx2Lanes>::child_overlap_masks(node, triangles, ids, count, masks);
}

template <>
void level_child_masks_in_lanes<SimdIsa::avx2>(const GridInfo& info, std::int32_t half,
                                               const TriangleVertices* triangles,
                                               const Voxel* node_lo, const std::uint32_t* pair_node,
                                               const std::uint32_t* pair_tri,
                                               const std::uint32_t* picked, std::uint32_t count,
                                               std::uint8_t* masks) {
  using Lanes = simd::OctantMaskLanes<simd::Avx2Lanes>;
  Lanes::masks_of(
      typename Lanes::LevelPairs{&info, half, triangles, node_lo, pair_node, pair_tri, picked},
      count, masks);
}

template <>
void propose_merges_with<SimdIsa::avx2>(const merge_detail::ProposeInputs& in, std::uint32_t first,
                                        std::uint32_t count) {
  simd::ProposeLanes<simd::Avx2Lanes>::propose(in, first, count);
}

template <>
void triangle_planes_in_lanes<SimdIsa::avx2>(const GridInfo& info,
                                             const TriangleVertices* triangles, std::uint32_t count,
                                             expand_detail::TrianglePlanes* out) {
  simd::TrianglePlanesLanes<simd::Avx2Lanes>::planes_of(info, triangles, count, out);
}

}  // namespace irgrid

#pragma GCC pop_options
