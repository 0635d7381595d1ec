// core/construction/compact_map.h: compacts the octree-form voxel map (collapse, then flatten).
//
// Pérard-Gayot et al. 2017, §4 (voxel-map update after merging): blocks of 8 children that all
// name the same cell collapse into one leaf, and up to 3 octree levels are grouped into one map
// level (a dense block of 8, 64 or 512 entries), so a lookup costs 1 + ceil(D / 3) dependent
// 4-byte reads instead of 1 + D.
#pragma once

#include <cstdint>
#include <vector>

#include "core/construction/cells.h"
#include "core/release_buffer.h"

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

/// Rebuilds the map with up to 3 octree levels per map level, chunk by chunk: the roots of a
/// chunk are old entries; each inner root gets a dense block of (2^min(depth, 3))^3 entries,
/// placed by a scan over the roots' block sizes, and the inner members of those blocks become the
/// roots of the next chunk (a stable selection, so blocks come out in the order of a serial
/// breadth-first walk). Every step is an executor primitive, so the map never leaves the device.
/// Consumes `depth` (collapse_map's) and the octree-form entries before the blocks are joined
/// into one array, so that the joining holds the new map twice but the old one no longer.
template <typename Exec>
void flatten_map(Exec& exec, GridArrays<Exec>& grid,
                 typename Exec::template Buffer<std::uint8_t>& depth_buffer) {
  using Indices = typename Exec::template Buffer<std::uint32_t>;
  const Entry* old = grid.entries.data();
  const std::uint8_t* depth = depth_buffer.data();
  const std::uint32_t top = grid.level_offsets[1];
  std::vector<typename Exec::template Buffer<Entry>> parts;
  parts.push_back(exec.template allocate<Entry>(top));  // the top level keeps its place
  Indices slots = exec.template allocate<std::uint32_t>(top);
  Indices roots = exec.template allocate<std::uint32_t>(top);
  {
    std::uint32_t *d_slots = slots.data(), *d_roots = roots.data();
    exec.for_each("flatten map", top,
                  [=] IRGRID_HD(std::size_t i) { d_slots[i] = d_roots[i] = std::uint32_t(i); });
  }
  std::uint32_t num_roots = top, written = top;
  while (num_roots > 0) {
    // Block size of every root, then where each block starts in this chunk's part.
    auto offsets = exec.template allocate<std::uint32_t>(num_roots);
    std::uint32_t* d_offsets = offsets.data();
    const std::uint32_t *d_slots = slots.data(), *d_roots = roots.data();
    exec.for_each("flatten map", num_roots, [=] IRGRID_HD(std::size_t r) {
      const std::uint32_t root = d_roots[r];
      const std::uint32_t steps = depth[root] < 3 ? depth[root] : 3;
      d_offsets[r] = old[root].log_dim() == 0 ? 0 : 1u << (3 * steps);
    });
    const std::uint64_t chunk = wide_sum(exec, "flatten map", d_offsets, num_roots);
    check_entry_count(written + chunk);
    exec.exclusive_scan("flatten map", d_offsets, d_offsets, num_roots);
    auto block = exec.template allocate<Entry>(chunk);
    auto reached = exec.template allocate<std::uint32_t>(chunk);
    Entry *d_block = block.data(), *d_parent = parts.back().data();
    std::uint32_t* d_reached = reached.data();
    const std::uint32_t base = written;
    exec.for_each("flatten map", num_roots, [=] IRGRID_HD(std::size_t r) {
      const std::uint32_t root = d_roots[r];
      if (old[root].log_dim() == 0) {
        d_parent[d_slots[r]] = old[root];
        return;
      }
      const std::uint32_t steps = depth[root] < 3 ? depth[root] : 3, side = 1u << steps;
      d_parent[d_slots[r]] = Entry::inner(steps, base + d_offsets[r]);
      for (std::uint32_t j = 0; j < side * side * side; ++j) {
        const std::uint32_t at = walk_octree(old, root, steps, j & (side - 1),
                                             j >> steps & (side - 1), j >> (2 * steps));
        d_block[d_offsets[r] + j] = old[at];
        d_reached[d_offsets[r] + j] = at;
      }
    });
    // The inner members of the new blocks are the next roots: their old entries, selected from
    // `reached`, then their slots, selected from the same array turned into the slot numbers.
    // Counted first, so that the selections take arrays of that count, not of the chunk's.
    const auto inner = [=] IRGRID_HD(std::size_t j, std::uint32_t) {
      return d_block[j].log_dim() != 0;
    };
    const std::uint32_t next_count = exec.transform_reduce(
        "flatten map", chunk, std::uint32_t(0),
        [] IRGRID_HD(std::uint32_t a, std::uint32_t b) { return a + b; },
        [=] IRGRID_HD(std::size_t j) { return std::uint32_t(inner(j, 0)); });
    Indices next_roots = exec.template allocate<std::uint32_t>(next_count);
    Indices next_slots = exec.template allocate<std::uint32_t>(next_count);
    exec.select_if("flatten map", d_reached, next_roots.data(), chunk, inner);
    exec.for_each("flatten map", chunk,
                  [=] IRGRID_HD(std::size_t j) { d_reached[j] = std::uint32_t(j); });
    exec.select_if("flatten map", d_reached, next_slots.data(), chunk, inner);
    release_buffer(reached);
    parts.push_back(std::move(block));
    slots = std::move(next_slots);
    roots = std::move(next_roots);
    num_roots = next_count;
    written += std::uint32_t(chunk);
  }
  release_buffer(slots);
  release_buffer(roots);
  release_buffer(depth_buffer);
  release_buffer(grid.entries);
  grid.entries = concatenate<Exec, Entry>(exec, "flatten map", parts, written);
  grid.info.num_entries = written;
  grid.level_offsets.clear();
}

/// Collapses and flattens the voxel map (after merging).
template <typename Exec>
void compact_map(Exec& exec, GridArrays<Exec>& grid) {
  auto depth = collapse_map(exec, grid);
  flatten_map(exec, grid, depth);
}

}  // namespace irgrid
