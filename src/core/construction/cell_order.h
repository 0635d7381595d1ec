// core/construction/cell_order.h: numbers the cells along a Morton curve of their lower corners.
//
// The octree levels emit their leaves level by level, and the top cells in x-fastest order, so
// cells that touch in space usually lie far apart in the cell array: a neighbour across a top
// cell's y or z face, or one level deeper, is a cache miss for every phase that looks at
// neighbours (merge, expansion) and for rays stepping from cell to cell. Along a Morton
// (Z-order) curve most neighbours are close in the array. This is a renumbering only: boxes,
// lists and the map's shape stay the same.
#pragma once

#include <bit>
#include <cstdint>

#include "core/construction/top_level_refs.h"
#include "core/release_buffer.h"

namespace irgrid {

/// The low 21 bits of x, spread to every third bit of the result (bit k to bit 3k).
IRGRID_HD inline std::uint64_t spread_bits_by_3(std::uint64_t x) {
  x &= 0x1fffffull;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

/// Morton key of a voxel corner: x, y and z (each shifted right by `drop`, then its low 21 bits)
/// interleaved, x in bit 0.
IRGRID_HD inline std::uint64_t morton_key(const std::int32_t corner[3], int drop) {
  return spread_bits_by_3(std::uint64_t(corner[0]) >> drop) |
         spread_bits_by_3(std::uint64_t(corner[1]) >> drop) << 1 |
         spread_bits_by_3(std::uint64_t(corner[2]) >> drop) << 2;
}

/// Bits per axis of the grid's largest voxel coordinate (what morton_key interleaves before it
/// drops any).
inline int morton_bits(const GridInfo& info) {
  std::int32_t largest = 1;
  for (int a = 0; a < 3; ++a)
    largest = info.virtual_dims[a] > largest ? info.virtual_dims[a] : largest;
  return int(std::bit_width(std::uint32_t(largest - 1)));
}

/// Renumbers `cells` (the leaves of all levels, before their reference ranges are set) in the
/// Morton order of their lower corners, and rewrites what names them: the leaf entries of the
/// voxel map and the cell of every (cell, triangle) pair. The order depends on the boxes only,
/// so the result is the same for any number of threads. Corners of more than 21 bits per axis
/// are ordered by their high 21 bits; ties keep their previous order (the sort is stable).
template <typename Exec>
void order_cells_spatially(Exec& exec, const GridInfo& info,
                           typename Exec::template Buffer<Cell>& cells,
                           typename Exec::template Buffer<Entry>& entries, RefPairs<Exec>& pairs,
                           std::uint32_t num_cells, std::uint32_t num_entries) {
  if (num_cells < 2) return;
  const int bits = morton_bits(info);
  const int drop = bits > 21 ? bits - 21 : 0;
  auto keys = exec.template allocate<std::uint64_t>(num_cells);
  auto order = exec.template allocate<std::uint32_t>(num_cells);
  std::uint64_t* d_keys = keys.data();
  std::uint32_t* d_order = order.data();
  const Cell* d_cells = cells.data();
  exec.for_each("cell order keys", num_cells, [=] IRGRID_HD(std::size_t i) {
    d_keys[i] = morton_key(d_cells[i].lo, drop);
    d_order[i] = std::uint32_t(i);
  });
  exec.sort_pairs("cell order sort", d_keys, d_order, num_cells, 3 * (bits - drop));
  release_buffer(keys);
  auto renumber = exec.template allocate<std::uint32_t>(num_cells);
  auto sorted = exec.template allocate<Cell>(num_cells);
  std::uint32_t* d_renumber = renumber.data();
  Cell* d_sorted = sorted.data();
  exec.for_each("cell order permute", num_cells, [=] IRGRID_HD(std::size_t k) {
    d_sorted[k] = d_cells[d_order[k]];
    d_renumber[d_order[k]] = std::uint32_t(k);
  });
  cells = std::move(sorted);
  Entry* d_entries = entries.data();
  exec.for_each("cell order entries", num_entries, [=] IRGRID_HD(std::size_t i) {
    const Entry e = d_entries[i];
    if (e.log_dim() == 0) d_entries[i] = Entry::leaf(d_renumber[e.index()]);
  });
  std::uint32_t* d_pair_cell = pairs.cell.data();
  exec.for_each("cell order pairs", pairs.count,
                [=] IRGRID_HD(std::size_t i) { d_pair_cell[i] = d_renumber[d_pair_cell[i]]; });
}

}  // namespace irgrid
