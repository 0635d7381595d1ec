// cpu/octant_masks.cpp: which lanes child_overlap_masks runs in. Compiled for the baseline
// target; the lanes live in build_lanes_avx2.cpp and build_lanes_avx512.cpp.
#include "cpu/octant_masks.h"

#include <cstdint>

#include "core/construction/octree_levels.h"

namespace irgrid {

void child_overlap_masks(const NodeSplit& node, const TriangleVertices* triangles,
                         std::uint64_t num_triangles, const std::uint32_t* ids, std::uint32_t count,
                         std::uint8_t* masks) {
  // A node of a few triangles would leave most lanes empty.
  if (count >= 4 && num_triangles * 9 < (std::uint64_t(1) << 31)) {
    if (cpu_has(SimdIsa::avx512))
      return child_overlap_masks_in_lanes<SimdIsa::avx512>(node, triangles, ids, count, masks);
    if (cpu_has(SimdIsa::avx2))
      return child_overlap_masks_in_lanes<SimdIsa::avx2>(node, triangles, ids, count, masks);
  }
  for (std::uint32_t k = 0; k < count; ++k)
    masks[k] = std::uint8_t(child_overlap_mask(node, triangles[ids[k]]));
}

void level_child_masks(const GridInfo& info, std::int32_t half, const TriangleVertices* triangles,
                       const Voxel* node_lo, std::uint64_t num_nodes,
                       const std::uint32_t* pair_node, const std::uint32_t* pair_tri,
                       std::uint64_t num_pairs, const std::uint32_t* picked, std::uint32_t count,
                       std::uint8_t* masks) {
  constexpr std::uint64_t kIndices = std::uint64_t(1) << 31;
  if (count >= 4 && std::uint64_t(info.num_triangles) * 9 < kIndices && num_nodes * 3 < kIndices &&
      num_pairs < kIndices) {
    if (cpu_has(SimdIsa::avx512))
      return level_child_masks_in_lanes<SimdIsa::avx512>(info, half, triangles, node_lo, pair_node,
                                                         pair_tri, picked, count, masks);
    if (cpu_has(SimdIsa::avx2))
      return level_child_masks_in_lanes<SimdIsa::avx2>(info, half, triangles, node_lo, pair_node,
                                                       pair_tri, picked, count, masks);
  }
  for (std::uint32_t k = 0; k < count; ++k) {
    const std::uint32_t pair = picked[k];
    masks[pair] = std::uint8_t(
        child_overlap_mask(info, node_lo[pair_node[pair]], half, triangles[pair_tri[pair]]));
  }
}

}  // namespace irgrid
