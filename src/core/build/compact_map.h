// core/build/compact_map.h: compacts the octree-form voxel map (collapse, then flatten).
//
// Pérard-Gayot et al. 2017, §4 (voxel-map update after merging): blocks of 8 children that all
// name the same cell collapse into one leaf, and up to 3 octree levels are grouped into one map
// level (a dense block of 8, 64 or 512 entries), so a lookup costs 1 + ceil(D / 3) dependent
// 4-byte reads instead of 1 + D.
#pragma once

#include <cstdint>
#include <vector>

#include "core/build/cells.h"

namespace irgrid {

/// Bottom-up over the octree levels: collapses uniform blocks and returns each entry's subtree
/// depth (0 for leaves).
template <typename Exec>
typename Exec::template Buffer<std::uint8_t> collapse_map(Exec& exec, GridArrays<Exec>& grid) {
  auto depth = exec.template allocate<std::uint8_t>(grid.entries.size());
  std::uint8_t* d_depth = depth.data();
  Entry* entries = grid.entries.data();
  for (std::size_t level = grid.level_offsets.size() - 1; level-- > 0;) {
    const std::uint32_t first = grid.level_offsets[level];
    const std::uint32_t count = grid.level_offsets[level + 1] - first;
    exec.for_each("collapse map", count, [=] IRGRID_HD(std::size_t k) {
      const std::size_t i = first + k;
      const Entry entry = entries[i];
      if (entry.log_dim() == 0) {
        d_depth[i] = 0;
        return;
      }
      const std::uint32_t child = entry.index();
      bool uniform = entries[child].log_dim() == 0;
      std::uint8_t deepest = 0;
      for (std::uint32_t c = 0; c < 8; ++c) {
        uniform &= entries[child + c].bits == entries[child].bits;
        deepest = d_depth[child + c] > deepest ? d_depth[child + c] : deepest;
      }
      if (uniform) entries[i] = entries[child];
      d_depth[i] = uniform ? 0 : std::uint8_t(deepest + 1);
    });
  }
  return depth;
}

/// Follows `steps` octree levels down from `entry` along the block coordinate (x, y, z) of a
/// dense block of side 2^steps, stopping early at a leaf.
IRGRID_HD inline std::uint32_t walk_octree(const Entry* entries, std::uint32_t entry,
                                           std::uint32_t steps, std::uint32_t x, std::uint32_t y,
                                           std::uint32_t z) {
  for (std::uint32_t s = 0; s < steps && entries[entry].log_dim() != 0; ++s) {
    const std::uint32_t bit = steps - 1 - s;
    entry = entries[entry].index() + ((x >> bit & 1) | (y >> bit & 1) << 1 | (z >> bit & 1) << 2);
  }
  return entry;
}

/// Rebuilds the map with up to 3 octree levels per map level. Works chunk by chunk: the roots of
/// a chunk are old entries; each inner root gets a dense block of (2^min(depth, 3))^3 entries
/// whose inner members become the roots of the next chunk. Runs on the host over host-visible
/// entries (the CPU executor's buffers); a CUDA version needs a parallel form of the same walk.
template <typename Exec>
void flatten_map(Exec& exec, GridArrays<Exec>& grid, const std::uint8_t* depth) {
  const Entry* old = grid.entries.data();
  const std::uint32_t top = grid.level_offsets[1];
  std::vector<Entry> out(old, old + top);  // the top level keeps its place
  std::vector<std::uint32_t> slots(top), roots(top);
  for (std::uint32_t i = 0; i < top; ++i)
    slots[i] = roots[i] = i;
  while (!slots.empty()) {
    std::vector<std::uint32_t> next_slots, next_roots;
    for (std::size_t r = 0; r < roots.size(); ++r) {
      const Entry root = old[roots[r]];
      if (root.log_dim() == 0) {
        out[slots[r]] = root;
        continue;
      }
      const std::uint32_t steps = depth[roots[r]] < 3 ? depth[roots[r]] : 3, side = 1u << steps;
      const auto block = std::uint32_t(out.size());
      if (std::uint64_t(block) + side * side * side > kMaxEntryTarget)
        throw Error(ErrorCode::limit_exceeded,
                    "voxel map: more than 2^30 - 1 entries (lower lambda2)");
      out[slots[r]] = Entry::inner(steps, block);
      out.resize(block + side * side * side);
      for (std::uint32_t j = 0; j < side * side * side; ++j) {
        const std::uint32_t reached = walk_octree(old, roots[r], steps, j & (side - 1),
                                                  j >> steps & (side - 1), j >> (2 * steps));
        out[block + j] = old[reached];
        if (old[reached].log_dim() != 0)
          next_slots.push_back(block + j), next_roots.push_back(reached);
      }
    }
    slots.swap(next_slots);
    roots.swap(next_roots);
  }
  grid.entries = exec.template allocate<Entry>(out.size());
  Entry* d_out = grid.entries.data();
  const Entry* h_out = out.data();
  exec.for_each("flatten map", out.size(), [=](std::size_t i) { d_out[i] = h_out[i]; });
  grid.info.num_entries = std::uint32_t(out.size());
  grid.level_offsets.clear();
}

/// Collapses and flattens the voxel map (after merging).
template <typename Exec>
void compact_map(Exec& exec, GridArrays<Exec>& grid) {
  const auto depth = collapse_map(exec, grid);
  flatten_map(exec, grid, depth.data());
}

}  // namespace irgrid
