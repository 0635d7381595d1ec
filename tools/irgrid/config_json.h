// tools/irgrid/config_json.h: a build's figures and grid parameters in the JSON that `build`
// and `bench` write (docs/bench-json.md).
#pragma once

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "irgrid/accelerator.h"

namespace irgrid::cli {

/// A grid's counts by the names `build` prints and the JSON uses (peak_build_bytes aside).
std::vector<std::pair<const char*, std::uint64_t>> grid_counts(const GridStats& grid);
/// A grid's bytes per array by name (empty_radii only when the grid has them).
std::vector<std::pair<const char*, std::uint64_t>> grid_array_bytes(const GridStats& grid);

/// Adds build_ms, build_phases_ms (the phases that ran), memory_bytes, memory_breakdown_bytes
/// and counts to a structure's JSON object; for grids also `config` (the grid parameters as
/// given) and, for irregular grids, `lambda2_used`, the λ2 its octrees used.
void add_build_stats_json(nlohmann::json& out, Structure structure, const BuildStats& stats,
                          const std::optional<BuildConfig>& grid);

}  // namespace irgrid::cli
