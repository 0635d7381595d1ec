// cpu/octant_masks.h: the children masks of an octree node's triangles, many triangles at once.
//
// The depth-first octrees (core/construction/octree_depth_first.h) ask child_overlap_mask of
// every triangle of a node they consider splitting: Sponza's octrees settle 2.2 million
// triangles, Crown's 32 million, with the exact separating-axis test (core/triangle_box.h). The
// scalar test spends most of its instructions on the axes (13 per triangle) and settles only
// 4 octants per SSE vector. Here one lane holds one triangle: 16 triangles (AVX-512) or 8 (AVX2)
// take each axis together, and only the triangles that need the exact test run it, packed into
// full registers. Every lane repeats the scalar test's float operations in the same order, so
// the masks are child_overlap_mask's, bit for bit (tests/test_octant_masks.cpp).
#pragma once

#include <cstdint>

#include "cpu/simd_walk.h"

namespace irgrid {

struct GridInfo;
struct NodeSplit;
struct TriangleVertices;
struct Voxel;

/// masks[k] = child_overlap_mask(node, triangles[ids[k]]) for k < count (ids below
/// num_triangles), in the widest SIMD lanes this CPU runs (cpu_has), or one triangle at a time
/// without them or where the triangles outgrow 32-bit gather indices.
void child_overlap_masks(const NodeSplit& node, const TriangleVertices* triangles,
                         std::uint64_t num_triangles, const std::uint32_t* ids, std::uint32_t count,
                         std::uint8_t* masks);

/// child_overlap_masks in the lanes of kIsa. Requires cpu_has(kIsa) and fewer than 2^31 / 9
/// triangles (32-bit gather indices).
template <SimdIsa kIsa>
void child_overlap_masks_in_lanes(const NodeSplit& node, const TriangleVertices* triangles,
                                  const std::uint32_t* ids, std::uint32_t count,
                                  std::uint8_t* masks);

/// The masks of a level's (node, triangle) pairs, each with its own node (the level-by-level
/// octrees, octree_levels.h): for k < count, with p = picked[k],
///   masks[p] = child_overlap_mask(info, node_lo[pair_node[p]], half, triangles[pair_tri[p]]).
/// In SIMD lanes where the CPU runs them and the pairs, nodes and triangles fit 32-bit gather
/// indices; one pair at a time otherwise.
void level_child_masks(const GridInfo& info, std::int32_t half, const TriangleVertices* triangles,
                       const Voxel* node_lo, std::uint64_t num_nodes,
                       const std::uint32_t* pair_node, const std::uint32_t* pair_tri,
                       std::uint64_t num_pairs, const std::uint32_t* picked, std::uint32_t count,
                       std::uint8_t* masks);

/// level_child_masks in the lanes of kIsa. Requires cpu_has(kIsa) and the 32-bit indices.
template <SimdIsa kIsa>
void level_child_masks_in_lanes(const GridInfo& info, std::int32_t half,
                                const TriangleVertices* triangles, const Voxel* node_lo,
                                const std::uint32_t* pair_node, const std::uint32_t* pair_tri,
                                const std::uint32_t* picked, std::uint32_t count,
                                std::uint8_t* masks);

}  // namespace irgrid
