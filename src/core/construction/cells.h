// core/construction/cells.h: one array of cells, one of references sorted per cell, one voxel map.
//
// Pérard-Gayot et al. 2017, §3.1, last step: the leaves of all octree levels are concatenated
// into the cell array and the (cell, triangle) pairs sorted into per-cell ranges. The sort is
// stable and every level emits each cell's triangles in ascending order, so every list comes out
// sorted ascending and free of duplicates, which merging and expansion rely on.
#pragma once

#include <bit>
#include <cstdint>
#include <vector>

#include "core/construction/cell_order.h"
#include "core/construction/narrow_cell.h"
#include "core/construction/octree_levels.h"
#include "core/release_buffer.h"
#include "irgrid/error.h"

namespace irgrid {

/// A built grid: scalars and the four arrays (buffers of the executor's memory space).
template <typename Exec>
struct GridArrays {
  GridInfo info{};
  typename Exec::template Buffer<Entry> entries;
  typename Exec::template Buffer<Cell> cells;
  /// The cells in 20 bytes from the host's assemblies until they are merged (narrow_cell.h);
  /// `cells` is empty meanwhile, and this empty otherwise. widen_cells ends it.
  typename Exec::template Buffer<NarrowCell> narrow_cells;
  typename Exec::template Buffer<std::uint32_t> refs;
  typename Exec::template Buffer<TriangleVertices> triangles;
  /// Empty radii of each top cell, one per octant (core/construction/empty_space.h); empty when the
  /// walk does not leap through empty space.
  typename Exec::template Buffer<std::uint8_t> empty_radii;
  /// Start of each octree level in `entries` while the map is in octree form (one block of 8
  /// children per inner entry); empty once the map is compacted.
  std::vector<std::uint32_t> level_offsets;
  /// References of the top grid (one per top cell a triangle overlaps), kept for statistics.
  std::uint32_t top_level_refs = 0;
  /// The construction budget in bytes (construction_budget), and whether it made the grid
  /// coarser than its parameters ask: a coarser top grid or octrees cut short.
  std::uint64_t budget_bytes = 0;
  bool budget_limited = false;
};

/// Sets each of the n cells' end to the next cell's begin (the last's to num_refs): for lists
/// laid out in cell order without gaps, in either cell form.
template <typename Exec, typename CellT>
void end_lists_at_successors(Exec& exec, const char* name, CellT* cells, std::uint32_t n,
                             std::uint32_t num_refs) {
  exec.for_each(name, n, [=] IRGRID_HD(std::size_t k) {
    cells[k].end = k + 1 < n ? cells[k + 1].begin : num_refs;
  });
}

/// Moves narrow cells (if any) into grid.cells in the wide form.
template <typename Exec>
void widen_cells(Exec& exec, GridArrays<Exec>& grid) {
  if (grid.narrow_cells.size() == 0) return;
  const std::uint32_t n = grid.info.num_cells;
  grid.cells = exec.template allocate<Cell>(n);
  Cell* wide = grid.cells.data();
  const NarrowCell* narrow = grid.narrow_cells.data();
  exec.for_each("widen cells", n, [=] IRGRID_HD(std::size_t i) { wide[i] = widened(narrow[i]); });
  release_buffer(grid.narrow_cells);
}

/// Concatenates per-level buffers into one of `total` elements.
template <typename Exec, typename T>
typename Exec::template Buffer<T> concatenate(
    Exec& exec, const char* name, const std::vector<typename Exec::template Buffer<T>>& parts,
    std::uint32_t total) {
  auto out = exec.template allocate<T>(total);
  std::uint32_t offset = 0;
  for (const auto& part : parts) {
    const T* in = part.data();
    T* d_out = out.data() + offset;
    exec.for_each(name, part.size(), [=] IRGRID_HD(std::size_t i) { d_out[i] = in[i]; });
    offset += std::uint32_t(part.size());
  }
  return out;
}

/// Moves the levels' entries into grid.entries (the octree-form map) and its level offsets.
template <typename Exec>
void take_level_entries(Exec& exec, OctreeLevels<Exec>& levels, GridArrays<Exec>& grid) {
  grid.entries =
      concatenate<Exec, Entry>(exec, "concatenate entries", levels.entries, levels.num_entries);
  grid.level_offsets.clear();
  std::uint32_t offset = 0;
  for (const auto& level : levels.entries) {
    grid.level_offsets.push_back(offset);
    offset += std::uint32_t(level.size());
  }
  grid.level_offsets.push_back(offset);
  levels.entries.clear();
}

/// Sorts the pairs by cell (stable) and writes each cell's [begin, end) range. Ranges follow
/// the cell order without gaps, empty cells included (begin == end at their place), so a cell's
/// end is the next cell's begin, which compressed cells rely on.
template <typename Exec>
typename Exec::template Buffer<std::uint32_t> sort_references(Exec& exec, RefPairs<Exec>& pairs,
                                                              Cell* cells,
                                                              std::uint32_t num_cells) {
  const int key_bits = std::max(1, int(std::bit_width(num_cells)));
  exec.sort_pairs("sort references", pairs.cell.data(), pairs.tri.data(), pairs.count, key_bits);
  auto counts = exec.template allocate<std::uint32_t>(num_cells);
  auto begins = exec.template allocate<std::uint32_t>(num_cells);
  std::uint32_t *d_counts = counts.data(), *d_begins = begins.data();
  const std::uint32_t* cell = pairs.cell.data();
  exec.for_each("reference counts", num_cells, [=] IRGRID_HD(std::size_t i) { d_counts[i] = 0; });
  exec.for_each("reference counts", pairs.count,
                [=] IRGRID_HD(std::size_t i) { atomic_add(&d_counts[cell[i]], 1u); });
  exec.exclusive_scan("reference ranges", d_counts, d_begins, num_cells);
  exec.for_each("reference ranges", num_cells, [=] IRGRID_HD(std::size_t i) {
    cells[i].begin = d_begins[i];
    cells[i].end = d_begins[i] + d_counts[i];
  });
  return std::move(pairs.tri);
}

/// Turns the octree levels into the final arrays (cells, sorted references, octree voxel map).
/// Consumes the levels: each part is freed once copied, so the build's later phases do not
/// hold the grid twice (`levels` keeps only its counts).
template <typename Exec>
void assemble_grid(Exec& exec, OctreeLevels<Exec>& levels, GridArrays<Exec>& grid) {
  if (levels.cells.size() != levels.entries.size())
    throw Error(ErrorCode::internal, "assemble_grid: octree levels built without their cells");
  take_level_entries(exec, levels, grid);
  grid.cells = concatenate<Exec, Cell>(exec, "concatenate cells", levels.cells, levels.num_cells);
  levels.cells.clear();
  std::vector<typename Exec::template Buffer<std::uint32_t>> cell_parts, tri_parts;
  for (auto& part : levels.pairs) {
    cell_parts.push_back(std::move(part.cell));
    tri_parts.push_back(std::move(part.tri));
  }
  levels.pairs.clear();
  RefPairs<Exec> pairs{{}, {}, levels.num_refs};
  pairs.cell =
      concatenate<Exec, std::uint32_t>(exec, "concatenate pairs", cell_parts, levels.num_refs);
  cell_parts.clear();
  pairs.tri =
      concatenate<Exec, std::uint32_t>(exec, "concatenate pairs", tri_parts, levels.num_refs);
  tri_parts.clear();
  order_cells_spatially(exec, grid.info, grid.cells, grid.entries, pairs, levels.num_cells,
                        levels.num_entries);
  grid.refs = sort_references(exec, pairs, grid.cells.data(), levels.num_cells);
  grid.info.num_cells = levels.num_cells;
  grid.info.num_refs = levels.num_refs;
  grid.info.num_entries = levels.num_entries;
}

}  // namespace irgrid
