// A build's figures and grid parameters in the JSON of `build` and `bench` (docs/bench-json.md).
#include "config_json.h"

#include "irgrid/build_config.h"

namespace irgrid::cli {

namespace {

/// Phase name -> value, for the phases that have one (PhaseTimes, PhaseBytes).
template <typename T>
nlohmann::json per_phase_json(const std::array<std::optional<T>, kBuildPhaseCount>& values) {
  nlohmann::json out = nlohmann::json::object();
  for (std::size_t p = 0; p < kBuildPhaseCount; ++p)
    if (values[p]) out[to_string(BuildPhase(p))] = *values[p];
  return out;
}

}  // namespace

std::vector<std::pair<const char*, std::uint64_t>> grid_counts(const GridStats& g) {
  return {{"top_level_references", g.top_level_references},
          {"cells", g.cells},
          {"references", g.references},
          {"entries", g.voxel_map_entries},
          {"top_x", g.top_dims[0]},
          {"top_y", g.top_dims[1]},
          {"top_z", g.top_dims[2]},
          {"depth", g.depth},
          {"compressed_cells", g.compressed_cells ? 1 : 0},
          {"budget_bytes", g.budget_bytes},
          {"budget_limited", g.budget_limited ? 1 : 0}};
}

std::vector<std::pair<const char*, std::uint64_t>> grid_array_bytes(const GridStats& g) {
  std::vector<std::pair<const char*, std::uint64_t>> out = {{"cells", g.cells_bytes},
                                                            {"references", g.references_bytes},
                                                            {"voxel_map", g.voxel_map_bytes},
                                                            {"triangles", g.triangles_bytes}};
  if (g.empty_radii_bytes > 0) out.emplace_back("empty_radii", g.empty_radii_bytes);
  return out;
}

void add_build_stats_json(nlohmann::json& out, Structure structure, const BuildStats& stats,
                          const std::optional<BuildConfig>& grid) {
  out["build_ms"] = stats.build_ms;
  out["build_phases_ms"] = per_phase_json(stats.phase_ms);
  out["memory_bytes"] = stats.memory_bytes;
  out["memory_breakdown_bytes"] = nlohmann::json::object();
  out["counts"] = nlohmann::json::object();
  if (stats.grid) {
    const GridStats& g = *stats.grid;
    for (const auto& [name, bytes] : grid_array_bytes(g))
      out["memory_breakdown_bytes"][name] = bytes;
    for (const auto& [name, count] : grid_counts(g))
      out["counts"][name] = count;
    out["counts"]["peak_build_bytes"] = g.peak_build_bytes;
    out["build_phase_peak_bytes"] = per_phase_json(g.phase_peak_bytes);
  }
  if (stats.bvh) {
    const BvhStats& b = *stats.bvh;
    out["memory_breakdown_bytes"] = {{"nodes", b.nodes_bytes},
                                     {"references", b.references_bytes},
                                     {"triangles", b.triangles_bytes}};
    out["counts"] = {{"nodes", b.nodes}, {"references", b.references}, {"depth", b.depth}};
  }
  if (!grid) return;
  out["config"] = {{"lambda1", grid->lambda1},
                   {"lambda2", grid->lambda2},
                   {"min_cells", grid->min_cells},
                   {"split_refs", grid->split_refs},
                   {"alpha", grid->alpha},
                   {"cost_ratio", grid->cost_ratio},
                   {"empty_aspect", grid->empty_aspect},
                   {"expansion_passes", grid->expansion_passes},
                   {"partial_expansion", grid->partial_expansion},
                   {"skip_empty", grid->skip_empty},
                   {"compress", grid->compress},
                   {"huge_pages", grid->huge_pages},
                   {"memory_budget", grid->memory_budget}};
  if (structure == Structure::irregular && stats.grid)
    out["lambda2_used"] = stats.grid->lambda2_used;
}

}  // namespace irgrid::cli
