// core/build/build_grid.h: the whole construction, phase by phase, over an executor.
//
// Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids", EG 2017:
// initial grid (top grid + octrees, §3.1), then merging (§3.2) and expansion (§3.3).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <string>

#include "core/build/cells.h"
#include "core/build/compact_map.h"
#include "core/build/expand.h"
#include "core/build/merge.h"
#include "core/build/octree_levels.h"
#include "core/build/top_grid.h"
#include "core/build/top_level_refs.h"
#include "irgrid/accelerator.h"
#include "irgrid/build_config.h"

namespace irgrid {

/// Per-top-cell octree depths (λ2) and their maximum D, capped so R << D fits the limits.
template <typename Exec>
typename Exec::template Buffer<std::int32_t> top_cell_depths(Exec& exec, GridInfo& info,
                                                             const RefPairs<Exec>& pairs,
                                                             const BuildConfig& config) {
  const std::uint32_t n = std::uint32_t(info.top_dims[0]) * std::uint32_t(info.top_dims[1]) *
                          std::uint32_t(info.top_dims[2]);
  auto depths = exec.template allocate<std::int32_t>(n);
  auto counts = exec.template allocate<std::uint32_t>(n);
  std::int32_t* d_depths = depths.data();
  std::uint32_t* d_counts = counts.data();
  exec.for_each("depth clear", n, [=] IRGRID_HD(std::size_t i) { d_counts[i] = 0; });
  const std::uint32_t* cell = pairs.cell.data();
  exec.for_each("depth count", pairs.count,
                [=] IRGRID_HD(std::size_t i) { atomic_add(&d_counts[cell[i]], 1u); });
  const Vec3<float> size = top_cell_size(info);
  const std::int32_t max_depth =
      config.shape == BuildConfig::Shape::uniform ? 0 : max_octree_depth(info);
  const float lambda2 = config.lambda2;
  exec.for_each("depth", n, [=] IRGRID_HD(std::size_t i) {
    d_depths[i] = octree_depth(size, lambda2, d_counts[i], max_depth);
  });
  const std::int32_t shift =
      exec.reduce("max depth", d_depths, n, std::int32_t(0),
                  [] IRGRID_HD(std::int32_t a, std::int32_t b) { return a > b ? a : b; });
  set_virtual_resolution(info, shift);
  return depths;
}

/// Wall time of the build's phases, in order; waits for the executor before each reading.
template <typename Exec>
class PhaseClock {
 public:
  PhaseClock(Exec& exec, std::map<std::string, double>& phases_ms,
             const PhaseObserver& on_phase = {})
      : exec_(exec), phases_ms_(phases_ms), on_phase_(on_phase) {}
  void lap(const char* phase) {
    exec_.synchronize();
    const auto now = std::chrono::steady_clock::now();
    phases_ms_[phase] += std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
    if (on_phase_) on_phase_(phase);
  }

 private:
  Exec& exec_;
  std::map<std::string, double>& phases_ms_;
  const PhaseObserver& on_phase_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/// Builds the grid over the triangles already gathered into grid.triangles; adds the time of
/// each phase to phases_ms and tells on_phase (when set) as each one ends.
template <typename Exec>
void build_grid(Exec& exec, GridArrays<Exec>& grid, const BuildConfig& config,
                std::map<std::string, double>& phases_ms, const PhaseObserver& on_phase = {}) {
  if (!(config.lambda2 >= 0) || !std::isfinite(config.lambda2))
    throw Error(ErrorCode::invalid_argument,
                "lambda2 = " + std::to_string(config.lambda2) + " must be a number >= 0");
  const auto count = std::uint32_t(grid.triangles.size());
  if (count == 0) throw Error(ErrorCode::invalid_argument, "a grid needs at least one triangle");
  const TriangleVertices* triangles = grid.triangles.data();
  PhaseClock clock(exec, phases_ms, on_phase);
  grid.info = plan_top_grid(exec, triangles, count, config);
  auto pairs = emit_top_level_refs(exec, triangles, grid.info);
  clock.lap("top grid");
  const auto depths = top_cell_depths(exec, grid.info, pairs, config);
  auto levels = build_octree_levels(exec, grid.info, triangles, std::move(pairs), depths.data(),
                                    config.shape);
  clock.lap("octree levels");
  assemble_grid(exec, levels, grid);
  clock.lap("cells and references");
  // Merging and expansion (paper §3.2-3.3) only for the irregular grid: the uniform and
  // two-level grids are the baselines without them.
  const bool irregular = config.shape == BuildConfig::Shape::irregular;
  if (irregular) merge_cells(exec, grid, config.alpha, config.cost_ratio);
  clock.lap("merge");
  compact_map(exec, grid);
  clock.lap("voxel map");
  if (irregular) expand_cells(exec, grid, config.expansion_passes, config.partial_expansion);
  clock.lap("expansion");
}

}  // namespace irgrid
