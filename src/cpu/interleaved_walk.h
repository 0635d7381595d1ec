// cpu/interleaved_walk.h: several grid walks advanced in lockstep on one CPU thread, so that
// their memory reads overlap.
//
// A ray's step through the grid is a chain of dependent reads: the voxel-map entries from the
// top level down (up to depth / 3 + 1 of them), the cell, its references, its triangles. On a
// scene larger than the L2 cache most of them miss, and a single walk leaves the core waiting
// on one read at a time. Here each pass over the lanes performs the same read for every lane,
// so the reads of different rays are independent and in flight together (memory-level
// parallelism; the same idea as the coroutine-interleaved index lookups of Psaropoulos et al.,
// "Interleaving with Coroutines", VLDB 2017). Each ray follows exactly the arithmetic of
// traverse_grid (irgrid/kernel/grid_traverse.h), so the hits are the same, bit for bit.
#pragma once

#include <cstdint>
#include <span>

#include "cpu/prefetch_triangle.h"
#include "cpu/ray_fields.h"
#include "irgrid/accelerator.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid {

/// Lanes of the interleaved walk: enough reads in flight to cover the latency of the L3 and
/// of memory, few enough that the lanes' states stay in L1.
inline constexpr int kWalkLanes = 8;

/// Traces ray i of `rays` into hit i of `hits` (and the work of each into work[i] when work is
/// not empty) with up to kWalkLanes walks interleaved. The same hits as
/// traverse_grid<kQuery, CellT> per ray.
template <Query kQuery, typename CellT>
void trace_interleaved(const GridView& grid, const RayFields& rays, const HitFields& hits,
                       std::span<RayWork> work) {
  struct Lane {
    GridWalk walk;
    TraversalCounters counters;
    std::uint32_t ray;
    Entry entry;
    std::int32_t level_shift;
    Cell cell;
    CellExit exit;
  };
  const CellT* cells = cell_array<CellT>(grid);
  const bool counted = !work.empty();
  Lane lanes[kWalkLanes];
  std::size_t next = 0;
  // Reads the top-level map entry of the lane's voxel: the first read of its next cell.
  const auto enter_cell = [&](Lane& lane) {
    lane.entry = grid.entries[top_entry_index(grid.info, lane.walk.voxel)];
    lane.level_shift = grid.info.shift;
  };
  // Gives the lane the next ray that enters the grid (the others are answered at once); false
  // when no ray is left.
  const auto start = [&](Lane& lane) {
    for (; next < rays.size(); ++next) {
      if (begin_walk(grid.info, rays[next], lane.walk)) {
        lane.ray = std::uint32_t(next++);
        lane.counters = {};
        enter_cell(lane);
        return true;
      }
      hits.write(next, kNoHit, 0, 0, 0);
      if (counted) work[next] = {};
    }
    return false;
  };
  int active = 0;
  while (active < kWalkLanes && start(lanes[active]))
    ++active;

  while (active > 0) {
    // The voxel map below the top level, one level per pass: each pass reads one entry per lane.
    for (bool descending = true; descending;) {
      descending = false;
      for (int l = 0; l < active; ++l) {
        Lane& lane = lanes[l];
        if (lane.entry.log_dim() == 0) continue;
        lane.entry = grid.entries[child_entry_index(lane.entry, lane.walk.voxel, lane.level_shift)];
        descending |= lane.entry.log_dim() != 0;
      }
    }
    // The cells, then the references, whose triangles are fetched ahead of the tests.
    for (int l = 0; l < active; ++l) {
      Lane& lane = lanes[l];
      lane.cell = load_cell(cells, lane.entry.index());
      lane.exit = cell_exit(lane.walk, lane.cell);
      leave_empty_space(grid, lane.walk, lane.cell, lane.exit);
    }
    for (int l = 0; l < active; ++l) {
      const Cell& cell = lanes[l].cell;
      for (std::uint32_t r = cell.begin; r < cell.end; ++r)
        prefetch_triangle(&grid.triangles[grid.refs[r]]);
    }
    // The tests and the step; a finished lane takes the next ray, or the last lane's place.
    for (int l = 0; l < active;) {
      Lane& lane = lanes[l];
      TraversalCounters* counters = counted ? &lane.counters : nullptr;
      if (counters) ++counters->cells;
      if (!test_cell_triangles<kQuery>(grid, lane.cell.begin, lane.cell.end, lane.walk, counters) &&
          step_past_cell(grid.info, lane.exit, lane.walk)) {
        enter_cell(lane);
        ++l;
        continue;
      }
      hits.write(lane.ray, walk_result(lane.walk));
      if (counted) work[lane.ray] = {lane.counters.cells, lane.counters.triangles};
      if (start(lane)) {
        ++l;  // its first cell is read in the next round
        continue;
      }
      lane = lanes[--active];  // not yet stepped this round: handled at l next
    }
  }
}

}  // namespace irgrid
