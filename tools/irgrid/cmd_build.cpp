// `irgrid build`: builds a structure and prints its statistics (counts, bytes, phase times).
#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "common.h"
#include "config_json.h"
#include "irgrid/error.h"
#include "irgrid/io/output_file.h"

namespace irgrid::cli {
namespace {

struct BuildOptions {
  std::string scene, json;
  StructureOptions structure;
};

nlohmann::json statistics_json(const Scene& scene, const std::string& scene_file,
                               const Accelerator& accelerator, const BuildConfig& grid) {
  const BuildStats& stats = accelerator.build_stats();
  const double per_triangle =
      scene.triangle_count() ? double(stats.memory_bytes) / double(scene.triangle_count()) : 0;
  nlohmann::json statistics = {{"scene", scene.name},
                               {"scene_file", scene_file},
                               {"triangles", scene.triangle_count()},
                               {"structure", to_string(accelerator.structure())},
                               {"backend", to_string(accelerator.backend())},
                               {"bytes_per_triangle", per_triangle}};
  add_build_stats_json(statistics, accelerator.structure(), stats,
                       is_grid(accelerator.structure()) ? std::optional(grid) : std::nullopt);
  return statistics;
}

void print_statistics(const Scene& scene, const Accelerator& accelerator, const BuildConfig& grid) {
  const BuildStats& stats = accelerator.build_stats();
  fmt::print("{} on {} over {} ({} triangles): built in {:.2f} ms\n",
             to_string(accelerator.structure()), to_string(accelerator.backend()), scene.name,
             scene.triangle_count(), stats.build_ms);
  for (std::size_t p = 0; p < kBuildPhaseCount; ++p)
    if (stats.phase_ms[p])
      fmt::print("  phase {:<22} {:>10.2f} ms\n", to_string(BuildPhase(p)), *stats.phase_ms[p]);
  if (stats.grid) {
    const GridStats& g = *stats.grid;
    if (accelerator.structure() == Structure::irregular && g.lambda2_used != grid.lambda2)
      fmt::print("  lambda2 used {:>26.4g} (raised from {:.4g} to aim at --min-cells {})\n",
                 g.lambda2_used, grid.lambda2, grid.min_cells);
    for (const auto& [name, count] : grid_counts(g))
      fmt::print("  {:<28} {:>10}\n", name, count);
    for (const auto& [name, size] : grid_array_bytes(g))
      fmt::print("  bytes {:<22} {:>10.2f} MiB\n", name, double(size) / 1048576.0);
  }
  if (stats.bvh) {
    const BvhStats& b = *stats.bvh;
    fmt::print("  {:<28} {:>10}\n  {:<28} {:>10}\n  {:<28} {:>10}\n", "nodes", b.nodes,
               "references", b.references, "depth", b.depth);
    for (const auto& [name, size] :
         {std::pair{"nodes", b.nodes_bytes}, std::pair{"references", b.references_bytes},
          std::pair{"triangles", b.triangles_bytes}})
      fmt::print("  bytes {:<22} {:>10.2f} MiB\n", name, double(size) / 1048576.0);
  }
  const double per_triangle =
      scene.triangle_count() ? double(stats.memory_bytes) / double(scene.triangle_count()) : 0;
  fmt::print("  memory {:>31.2f} MiB ({:.1f} bytes per triangle)\n",
             double(stats.memory_bytes) / 1048576.0, per_triangle);
  if (stats.grid)
    fmt::print("  peak memory during the build {:>9.2f} MiB\n",
               double(stats.grid->peak_build_bytes) / 1048576.0);
}

void run_build(const BuildOptions& o) {
  if (!o.json.empty()) check_writable(o.json);
  const Scene scene = load_scene_reporting(o.scene);
  const auto accelerator = build_reporting(scene, o.structure);
  print_statistics(scene, *accelerator, o.structure.grid);
  if (o.json.empty()) return;
  const auto statistics = statistics_json(scene, o.scene, *accelerator, o.structure.grid);
  write_file_whole(o.json, statistics.dump(2) + '\n');
}

}  // namespace

void add_build_command(CLI::App& app) {
  auto o = std::make_shared<BuildOptions>();
  auto* cmd = app.add_subcommand("build", "Build a structure and print its statistics");
  cmd->add_option("scene", o->scene, "Scene file or builtin:NAME[:N]")->required();
  add_structure_options(cmd, o->structure);
  cmd->add_option("--json", o->json, "Write the statistics as JSON to this file");
  cmd->callback([o] { run_build(*o); });
}

}  // namespace irgrid::cli
