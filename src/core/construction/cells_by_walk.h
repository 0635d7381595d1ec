// core/construction/cells_by_walk.h: the level-by-level octrees assembled on the host, unsorted.
//
// assemble_grid (cells.h) takes every level's leaves as 32-byte cells, concatenates them, sorts
// them into Morton order into a second array (cell_order.h), then radix-sorts all (cell,
// triangle) pairs with a copy of them. Where the host walks the map (Exec::kDepthFirstOctrees)
// and corners fit the Morton key (depth_first_applies), the order comes from walking the
// octrees instead (octree_walk.h): the cells are written once, in it, in the narrow form where
// they fit (narrow_cell.h), and the references are dropped into their lists, each list then
// sorted on its own. The grid is the same, bit for bit (GridBuild.WalkingTheLevelsAssembles...,
// GridLimits.BudgetLimitedOctreesEqualEitherWay). This is the CPU's path when the depth-first
// octrees pass the construction budget (build_grid.h), as on the 10M-triangle hairball, where
// the sorts' copies took the build to 3.7 times its grid (docs/benchmarks.md).
#pragma once

#include <algorithm>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/construction/cells.h"
#include "core/construction/octree_walk.h"
#include "core/release_buffer.h"
#include "irgrid/error.h"

namespace irgrid {

/// Writes the references of `parts` ((cell, triangle) pairs naming cells below num_cells, each
/// pair once) into lists in cell order without gaps, each ascending. Consumes the parts. Leaves
/// each cell's end (one past its last reference; its begin is the previous cell's end, or 0) in
/// `ends` (num_cells values). Host executors only.
template <typename Exec>
typename Exec::template Buffer<std::uint32_t> scatter_references(Exec& exec,
                                                                 std::vector<RefPairs<Exec>>& parts,
                                                                 std::uint32_t num_cells,
                                                                 std::uint32_t num_refs,
                                                                 std::uint32_t* ends) {
  exec.for_each("reference counts", num_cells, [=](std::size_t k) { ends[k] = 0; });
  for (const RefPairs<Exec>& part : parts) {
    const std::uint32_t* cell = part.cell.data();
    exec.for_each("reference counts", part.count,
                  [=](std::size_t i) { atomic_add(&ends[cell[i]], 1u); });
  }
  exec.exclusive_scan("reference ranges", ends, ends, num_cells);
  auto refs = exec.template allocate<std::uint32_t>(num_refs);
  std::uint32_t* d_refs = refs.data();
  // Each cell's begin is its list's cursor until all are in; then it is the cell's end.
  for (RefPairs<Exec>& part : parts) {
    const std::uint32_t *cell = part.cell.data(), *tri = part.tri.data();
    exec.for_each("reference scatter", part.count,
                  [=](std::size_t i) { d_refs[atomic_add(&ends[cell[i]], 1u)] = tri[i]; });
    part = {};
  }
  parts.clear();
  // Lists hold a few references each (the 10M hairball: 2.2 on average).
  exec.for_each("reference sort", num_cells, [=](std::size_t k) {
    std::sort(d_refs + (k == 0 ? 0 : ends[k - 1]), d_refs + ends[k]);
  });
  return refs;
}

/// Turns the octree levels, built without cells (build_octree_levels), into the grid's arrays
/// as assemble_grid does, the cells in grid.narrow_cells where the virtual grid fits them and
/// `allow_narrow` (else in grid.cells). Consumes the levels. Requires
/// depth_first_applies(grid.info) and a host executor.
template <typename Exec>
void assemble_grid_by_walk(Exec& exec, OctreeLevels<Exec>& levels, GridArrays<Exec>& grid,
                           bool allow_narrow = true) {
  const GridInfo& info = grid.info;
  if (!depth_first_applies(info))
    throw Error(ErrorCode::internal, "assemble_grid_by_walk: corners past the Morton key");
  const std::uint32_t n = std::uint32_t(info.top_dims[0]) * std::uint32_t(info.top_dims[1]) *
                          std::uint32_t(info.top_dims[2]);
  const std::uint32_t num_cells = levels.num_cells, num_refs = levels.num_refs;
  take_level_entries(exec, levels, grid);
  Entry* entries = grid.entries.data();
  // Top cell t's root is entry t; an inner entry names its first child in the whole map.
  const auto walk = [&info, entries](std::uint32_t t, const auto& visit) {
    walk_octree(
        info, t, t, [entries](std::uint32_t, std::uint64_t i) { return entries[i]; }, visit);
  };
  // A leaf's new number is its rank in the walk; renumber maps the levels' numbers to it.
  auto renumber = exec.template allocate<std::uint32_t>(num_cells);
  std::uint32_t* d_renumber = renumber.data();
  {
    auto leaves = exec.template allocate<std::uint32_t>(n);
    auto cell_base = exec.template allocate<std::uint32_t>(n);
    std::uint32_t *d_leaves = leaves.data(), *d_cell_base = cell_base.data();
    exec.for_each("walk leaves", n, [&, d_leaves](std::size_t t) {
      std::uint32_t count = 0;
      walk(std::uint32_t(t),
           [&](std::uint32_t, std::uint64_t, Entry e, Voxel) { count += e.log_dim() == 0; });
      d_leaves[t] = count;
    });
    {
      const auto order = top_cells_in_morton_order(exec, info);
      auto scratch = exec.template allocate<std::uint32_t>(n);
      if (bases_in_order(exec, order.data(), d_leaves, scratch.data(), d_cell_base, n) != num_cells)
        throw Error(ErrorCode::internal,
                    "assemble_grid_by_walk: the map's leaves are not its cells");
    }
    exec.for_each("walk leaves", n, [&, d_cell_base](std::size_t t) {
      std::uint32_t k = d_cell_base[t];
      walk(std::uint32_t(t), [&](std::uint32_t, std::uint64_t i, Entry e, Voxel) {
        if (e.log_dim() != 0) return;
        d_renumber[e.index()] = k;
        entries[i] = Entry::leaf(k++);
      });
    });
  }
  for (RefPairs<Exec>& part : levels.pairs) {
    std::uint32_t* cell = part.cell.data();
    exec.for_each("walk pairs", part.count, [=](std::size_t i) { cell[i] = d_renumber[cell[i]]; });
  }
  // The renumbering is done: its buffer takes the lists' ends. The cells come last, once the
  // pairs are gone: they and the pairs were the assembly's largest arrays.
  std::uint32_t* ends = d_renumber;
  grid.refs = scatter_references(exec, levels.pairs, num_cells, num_refs, ends);
  const auto write_cells = [&](auto& buffer) {
    using CellT = std::remove_reference_t<decltype(buffer[0])>;
    buffer = exec.template allocate<CellT>(num_cells);
    CellT* cells = buffer.data();
    exec.for_each("walk cells", n, [&, cells](std::size_t t) {
      walk(std::uint32_t(t), [&](std::uint32_t l, std::uint64_t, Entry e, Voxel lo) {
        if (e.log_dim() != 0) return;
        const std::uint32_t k = e.index();
        const std::int32_t corner[3] = {lo.x, lo.y, lo.z};
        set_cube(cells[k], corner, std::int32_t(1) << (info.shift - std::int32_t(l)),
                 k == 0 ? 0 : ends[k - 1]);
        cells[k].end = ends[k];
      });
    });
  };
  if (allow_narrow && fits_compact_cells(info))
    write_cells(grid.narrow_cells);
  else
    write_cells(grid.cells);
  grid.info.num_cells = num_cells;
  grid.info.num_refs = num_refs;
  grid.info.num_entries = levels.num_entries;
}

}  // namespace irgrid
