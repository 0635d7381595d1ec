// core/construction/build_grid.h: the whole construction, phase by phase, over an executor.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017:
// initial grid (top grid + octrees, §3.1), then merging (§3.2) and expansion (§3.3).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "core/construction/cells.h"
#include "core/construction/cells_by_walk.h"
#include "core/construction/compact_cells.h"
#include "core/construction/compact_map.h"
#include "core/construction/empty_space.h"
#include "core/construction/expand.h"
#include "core/construction/merge.h"
#include "core/construction/octree_depth_first.h"
#include "core/construction/octree_levels.h"
#include "core/construction/top_grid.h"
#include "core/construction/top_level_refs.h"
#include "core/number_text.h"
#include "core/release_buffer.h"
#include "irgrid/accelerator.h"
#include "irgrid/build_config.h"

namespace irgrid {

/// The octree depths of a build (paper §3.1, and our count rule: BuildConfig::split_refs).
template <typename Exec>
struct OctreeDepths {
  typename Exec::template Buffer<std::int32_t> per_top_cell;        ///< λ2 depth of each top cell
  typename Exec::template Buffer<std::uint32_t> refs_per_top_cell;  ///< top-level references
  std::int32_t deepest_lambda2 = 0;  ///< the largest per-top-cell depth
  std::int32_t count_split = 0;      ///< the depth count splits may reach; 0 when none can
};

/// Per-top-cell octree depths, and the grid's depth D (info.shift): the deepest level any node
/// may reach, capped so R << D fits the limits. A top cell's depth follows λ2 (raised in small
/// irregular grids, effective_lambda2); one holding more
/// than config.split_refs references may also split nodes by count down to compact_octree_depth.
template <typename Exec>
OctreeDepths<Exec> plan_octree_depths(Exec& exec, GridInfo& info, const RefPairs<Exec>& pairs,
                                      const BuildConfig& config) {
  const std::uint32_t n = std::uint32_t(info.top_dims[0]) * std::uint32_t(info.top_dims[1]) *
                          std::uint32_t(info.top_dims[2]);
  OctreeDepths<Exec> out{exec.template allocate<std::int32_t>(n),
                         exec.template allocate<std::uint32_t>(n)};
  std::int32_t* d_depths = out.per_top_cell.data();
  std::uint32_t* d_counts = out.refs_per_top_cell.data();
  exec.for_each("depth clear", n, [=] IRGRID_HD(std::size_t i) { d_counts[i] = 0; });
  const std::uint32_t* cell = pairs.cell.data();
  exec.for_each("depth count", pairs.count,
                [=] IRGRID_HD(std::size_t i) { atomic_add(&d_counts[cell[i]], 1u); });
  const Vec3<float> size = top_cell_size(info);
  const std::int32_t max_depth =
      config.shape == BuildConfig::Shape::uniform ? 0 : max_octree_depth(info);
  // The baselines keep the paper's λ2, as they keep its one depth per top cell.
  const float lambda2 = config.shape == BuildConfig::Shape::irregular
                            ? float(effective_lambda2(config, pairs.count))
                            : config.lambda2;
  const float flat = flat_cell_extent(info);
  exec.for_each("depth", n, [=] IRGRID_HD(std::size_t i) {
    d_depths[i] = octree_depth(size, lambda2, d_counts[i], max_depth, flat);
  });
  out.deepest_lambda2 =
      exec.reduce("max depth", d_depths, n, std::int32_t(0),
                  [] IRGRID_HD(std::int32_t a, std::int32_t b) { return a > b ? a : b; });
  // A child holds a subset of its parent's references, so only top cells above the threshold
  // can ever split by count.
  if (config.split_refs > 0 && config.shape == BuildConfig::Shape::irregular) {
    const std::uint32_t most =
        exec.reduce("most references", d_counts, n, std::uint32_t(0),
                    [] IRGRID_HD(std::uint32_t a, std::uint32_t b) { return a > b ? a : b; });
    if (most > config.split_refs) out.count_split = compact_octree_depth(info);
  }
  set_virtual_resolution(info, std::max(out.deepest_lambda2, out.count_split));
  return out;
}

/// Wall time of the build's phases, in order; waits for the executor before each reading.
/// With `phase_peaks`, also the executor's memory peak within each phase (memory_peak), which
/// it restarts at each phase: the caller's peak of the whole build is then the largest of them
/// and of the executor's peak after the last phase.
template <typename Exec>
class PhaseClock {
 public:
  PhaseClock(Exec& exec, PhaseTimes& phases_ms, PhaseObserver on_phase = {},
             PhaseBytes* phase_peaks = nullptr)
      : exec_(exec),
        phases_ms_(phases_ms),
        on_phase_(std::move(on_phase)),
        phase_peaks_(phase_peaks) {
    if (phase_peaks_) exec_.reset_memory_peak();
  }
  void lap(BuildPhase phase) {
    exec_.synchronize();
    const auto now = std::chrono::steady_clock::now();
    auto& ms = phases_ms_[std::size_t(phase)];
    ms = ms.value_or(0.0) + std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
    if (phase_peaks_) {
      auto& peak = (*phase_peaks_)[std::size_t(phase)];
      peak = std::max<std::uint64_t>(peak.value_or(0), exec_.memory_peak());
      exec_.reset_memory_peak();
    }
    if (on_phase_) on_phase_(phase);
  }

 private:
  Exec& exec_;
  PhaseTimes& phases_ms_;
  PhaseObserver on_phase_;
  PhaseBytes* phase_peaks_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/// Splits of octree nodes holding more references than this must separate them
/// (OctreeRule::depth_split_pays); irregular grids only. Nodes this full are rare in real
/// scenes: with 2048 the shared scenes' grids stay bit for bit those of the paper's rules; with
/// 64, Conference lost 8.5% of its cells (and overlap:30000 built in a third of the time,
/// without reaching the budget). Below it, the construction budget bounds what a runaway
/// octree can take.
inline constexpr std::uint32_t kUnpaidSplitRefs = 2048;

/// The top-level references of a planned top grid, counted per triangle (count_top_level_refs).
template <typename Exec>
struct TopLevelCounts {
  typename Exec::template Buffer<std::uint32_t> offsets;
  std::uint64_t total = 0;
};

/// Plans the top grid (grid.info) and counts its (top cell, triangle) pairs. When the pairs
/// would pass grid.budget_bytes (or the 30-bit limit), the top grid is planned again with λ1
/// divided by 8 (half the cells per axis) until they fit or it is one cell, and
/// grid.budget_limited is set: overlapping triangles (a stack of copies, or large ones crossing
/// the scene) land in most top cells, and a finer grid would not separate them.
template <typename Exec>
TopLevelCounts<Exec> plan_top_grid_within_budget(Exec& exec, GridArrays<Exec>& grid,
                                                 const BuildConfig& config) {
  const auto count = std::uint32_t(grid.triangles.size());
  const TriangleVertices* triangles = grid.triangles.data();
  BuildConfig top = config;
  auto offsets = exec.template allocate<std::uint32_t>(std::size_t(count) + 1);
  const auto fits = [&](std::uint64_t refs, std::uint64_t slack) {
    return refs <= slack * kMaxEntryTarget &&
           top_level_pair_bytes(refs) <= slack * grid.budget_bytes;
  };
  for (;;) {
    grid.info = plan_top_grid(exec, triangles, count, top);
    const bool one_cell =
        grid.info.top_dims[0] == 1 && grid.info.top_dims[1] == 1 && grid.info.top_dims[2] == 1;
    // The exact count costs a triangle/box test per top cell of each triangle's box: it is
    // made only where that bound is within 8 budgets, so that its work stays within them.
    if (one_cell || fits(top_level_refs_bound(exec, triangles, grid.info), 8)) {
      const std::uint64_t total = count_top_level_refs(exec, triangles, grid.info, offsets.data());
      if (one_cell || fits(total, 1)) return {std::move(offsets), total};
    }
    top.lambda1 /= 8;
    grid.budget_limited = true;
  }
}

/// The initial grid (paper §3.1) over the triangles already gathered into grid.triangles: top
/// grid, octrees, one cell array with sorted reference lists, the voxel map in octree form.
/// Returns the deepest λ2 depth (below it, only count splits refine the grid).
template <typename Exec>
std::int32_t build_initial_grid(Exec& exec, GridArrays<Exec>& grid, const BuildConfig& config,
                                PhaseClock<Exec>& clock) {
  if (!(config.lambda2 >= 0) || !std::isfinite(config.lambda2))
    throw Error(ErrorCode::invalid_argument,
                "lambda2 = " + number_text(config.lambda2) + " must be a number >= 0");
  const auto count = std::uint32_t(grid.triangles.size());
  if (count == 0) throw Error(ErrorCode::invalid_argument, "a grid needs at least one triangle");
  const TriangleVertices* triangles = grid.triangles.data();
  grid.budget_bytes = construction_budget(config, count, exec.memory_budget());
  exec.limit_cached_memory(grid.budget_bytes);
  grid.budget_limited = false;
  auto counts = plan_top_grid_within_budget(exec, grid, config);
  clock.lap(BuildPhase::top_grid);
  auto pairs =
      emit_top_level_refs(exec, triangles, grid.info, std::move(counts.offsets), counts.total);
  grid.top_level_refs = pairs.count;
  clock.lap(BuildPhase::top_level_references);
  OctreeDepths<Exec> depths = plan_octree_depths(exec, grid.info, pairs, config);
  const bool irregular = config.shape == BuildConfig::Shape::irregular;
  const OctreeRule rule{depths.per_top_cell.data(), config.shape == BuildConfig::Shape::two_level,
                        config.split_refs, depths.count_split, irregular ? kUnpaidSplitRefs : 0};
  // After the octrees, the last to read the depths: they go before the cells are assembled.
  const auto plan_empty_space = [&] {
    if (config.skip_empty && irregular) {
      grid.empty_radii = empty_space_radii(exec, grid.info, depths.refs_per_top_cell.data());
      clock.lap(BuildPhase::empty_space);
    }
    release_buffer(depths.per_top_cell);
    release_buffer(depths.refs_per_top_cell);
  };
  if constexpr (Exec::kDepthFirstOctrees) {
    if (depth_first_applies(grid.info)) {
      try {
        auto octrees =
            build_top_cell_octrees(exec, grid.info, triangles, pairs,
                                   depths.refs_per_top_cell.data(), rule, grid.budget_bytes);
        pairs = {};
        clock.lap(BuildPhase::octree_levels);
        plan_empty_space();
        assemble_top_cell_octrees(exec, octrees, grid);
        clock.lap(BuildPhase::cells_and_references);
        return depths.deepest_lambda2;
      } catch (const depth_first_detail::BudgetExceeded&) {
        // The complete octrees do not fit: the level-by-level build finds the last level that
        // does, as the CUDA build would, from the same pairs (sorted by top cell now, which
        // leaves every list it makes as it was).
        exec.release_cached_memory();
      }
    }
  }
  // The host walks the octrees into Morton order (cells_by_walk.h), so the levels need no cells.
  const bool by_walk = Exec::kDepthFirstOctrees && depth_first_applies(grid.info);
  auto levels = build_octree_levels(exec, grid.info, triangles, std::move(pairs), rule,
                                    grid.budget_bytes, !by_walk);
  grid.budget_limited |= levels.budget_limited;
  clock.lap(BuildPhase::octree_levels);
  plan_empty_space();
  if constexpr (Exec::kDepthFirstOctrees) {
    if (by_walk) assemble_grid_by_walk(exec, levels, grid);
  }
  if (!by_walk) assemble_grid(exec, levels, grid);
  clock.lap(BuildPhase::cells_and_references);
  return depths.deepest_lambda2;
}

/// Builds the grid over the triangles already gathered into grid.triangles; adds the time of
/// each phase to phases_ms, tells on_phase (when set) as each one ends and, with phase_peaks,
/// records the executor's memory peak of each phase there (PhaseClock).
/// With `compact` (not null) and a grid that fits them (fits_compact_cells), the cells are
/// compressed (compress_cells: the compress phase, before expansion) into *compact, grid.cells
/// is released and the 16-byte cells expand; otherwise *compact is left empty and grid.cells
/// expand. Both give the same boxes.
template <typename Exec>
void build_grid(Exec& exec, GridArrays<Exec>& grid, const BuildConfig& config,
                PhaseTimes& phases_ms, const PhaseObserver& on_phase = {},
                PhaseBytes* phase_peaks = nullptr,
                typename Exec::template Buffer<CompactCell>* compact = nullptr) {
  PhaseClock clock(exec, phases_ms, on_phase, phase_peaks);
  const std::int32_t deepest_lambda2 = build_initial_grid(exec, grid, config, clock);
  // Merging and expansion (paper §3.2-3.3) only for the irregular grid: the uniform and
  // two-level grids are the baselines without them.
  const bool irregular = config.shape == BuildConfig::Shape::irregular;
  if (irregular) merge_cells(exec, grid, config.alpha, config.cost_ratio, config.empty_aspect);
  widen_cells(exec, grid);  // the merged cells, far fewer, in the form the later phases read
  clock.lap(BuildPhase::merge);
  compact_map(exec, grid);
  clock.lap(BuildPhase::voxel_map);
  const bool compressed = compact && fits_compact_cells(grid.info);
  if (compressed) {
    compress_cells(exec, grid, *compact);
    release_buffer(grid.cells);
    clock.lap(BuildPhase::compress);
  }
  // Partial growth moves in voxels of the λ2 depth: finer steps, which count-split cells bring
  // to the whole grid, cost twice the expansion work on Sponza for a few % fewer tests per ray.
  const std::int32_t growth_quantum = std::int32_t(1) << (grid.info.shift - deepest_lambda2);
  if (irregular) {
    if (compressed)
      expand_compact_cells(exec, grid, *compact, config.expansion_passes, config.partial_expansion,
                           growth_quantum);
    else
      expand_cells(exec, grid, config.expansion_passes, config.partial_expansion, growth_quantum);
  }
  clock.lap(BuildPhase::expansion);
}

}  // namespace irgrid
