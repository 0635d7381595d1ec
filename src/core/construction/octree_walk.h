// core/construction/octree_walk.h: visits octree-form maps top cell by top cell in Morton order.
//
// Top cells are aligned blocks of 2^shift voxels per axis, and an octree's children are
// numbered as Morton digits (bit 0 x, bit 1 y, bit 2 z), so taking the top cells in the Morton
// order of their corners and each octree depth first, children in ascending order, meets the
// leaves in the Morton order of their lower corners: the order cell_order.h sorts cells into,
// without the sort, wherever corners fit its key (depth_first_applies). Both host assemblies
// (octree_depth_first.h, cells_by_walk.h) lay out their cells this way.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

#include "core/construction/cell_order.h"
#include "core/construction/octree_levels.h"
#include "core/release_buffer.h"

namespace irgrid {

/// Whether walking the octrees meets the leaves in cell_order.h's order (the host's assemblies,
/// build_top_cell_octrees and assemble_grid_by_walk, give the level-by-level build's grid):
/// corners must fit the 21 bits per axis of the Morton key, so that no two cells tie.
inline bool depth_first_applies(const GridInfo& info) {
  return morton_bits(info) <= 21;
}

/// The top cells (x-fastest indices) in the Morton order of their corners.
template <typename Exec>
typename Exec::template Buffer<std::uint32_t> top_cells_in_morton_order(Exec& exec,
                                                                        const GridInfo& info) {
  const std::uint32_t n = std::uint32_t(info.top_dims[0]) * std::uint32_t(info.top_dims[1]) *
                          std::uint32_t(info.top_dims[2]);
  auto keys = exec.template allocate<std::uint64_t>(n);
  auto order = exec.template allocate<std::uint32_t>(n);
  std::uint64_t* d_keys = keys.data();
  std::uint32_t* d_order = order.data();
  exec.for_each("top-cell order", n, [=] IRGRID_HD(std::size_t i) {
    const Voxel v = top_cell_corner(info, std::uint32_t(i));
    const std::int32_t corner[3] = {v.x, v.y, v.z};
    d_keys[i] = morton_key(corner, 0);
    d_order[i] = std::uint32_t(i);
  });
  exec.sort_pairs("top-cell order", d_keys, d_order, n, std::max(1, 3 * morton_bits(info)));
  return order;
}

/// base[t]: the sum of counts[u] over the top cells u before t in `order` (a permutation of the
/// n top cells, top_cells_in_morton_order), the first of t's items when every top cell's items
/// follow one another in that order. Returns the sum of all counts. `scratch` holds n values.
template <typename Exec>
std::uint64_t bases_in_order(Exec& exec, const std::uint32_t* order, const std::uint32_t* counts,
                             std::uint32_t* scratch, std::uint32_t* base, std::uint32_t n) {
  exec.for_each("top-cell bases", n, [=](std::size_t k) { scratch[k] = counts[order[k]]; });
  const std::uint64_t total = wide_sum(exec, "top-cell bases", scratch, n);
  exec.exclusive_scan("top-cell bases", scratch, scratch, n);
  exec.for_each("top-cell bases", n, [=](std::size_t k) { base[order[k]] = scratch[k]; });
  return total;
}

/// Walks the octree of top cell t depth first, children in ascending order (host code): calls
/// visit(level, index, entry, lo) for every node, `index` naming it as entry_at does and `lo`
/// being its lower voxel. entry_at(level, index) is the node's map entry; the root is
/// (0, root), an inner entry's children are (level + 1, entry.index() + 0..7).
template <typename EntryAt, typename Visit>
void walk_octree(const GridInfo& info, std::uint32_t t, std::uint64_t root, EntryAt&& entry_at,
                 Visit&& visit) {
  struct Pending {
    std::uint32_t level;
    std::uint64_t index;
    Voxel lo;
  };
  // At most 7 siblings waiting per level on the path, and the next node; depths stay below 25
  // (kMaxVirtualResolution).
  std::array<Pending, 8 * 26> pending;
  std::size_t size = 0;
  pending[size++] = {0, root, top_cell_corner(info, t)};
  while (size != 0) {
    const Pending at = pending[--size];
    const Entry e = entry_at(at.level, at.index);
    visit(at.level, at.index, e, at.lo);
    if (e.log_dim() == 0) continue;
    const std::int32_t half = std::int32_t(1) << (info.shift - std::int32_t(at.level) - 1);
    for (std::uint32_t child = 8; child-- > 0;)
      pending[size++] = {at.level + 1, e.index() + child, child_corner(at.lo, half, child)};
  }
}

}  // namespace irgrid
