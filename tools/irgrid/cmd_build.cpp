// `irgrid build`: builds a structure and prints its statistics (counts, bytes, phase times).
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "common.h"
#include "config_json.h"
#include "irgrid/error.h"
#include "irgrid/io/output_file.h"
#include "irgrid/kernel/grid_traverse.h"

namespace irgrid::cli {
namespace {

struct BuildOptions {
  std::string scene, json;
  StructureOptions structure;
  bool fingerprint = false;
};

/// FNV-1a over `bytes` bytes at `data`, continuing from `hash`.
std::uint64_t fnv1a(const void* data, std::size_t bytes, std::uint64_t hash) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i)
    hash = (hash ^ p[i]) * 0x100000001b3ull;
  return hash;
}

/// A hash of a CPU grid's cells, reference lists and voxel map: equal fingerprints mean the
/// same grid bit for bit (what a change to the construction that must not change the grid is
/// checked with).
std::uint64_t grid_fingerprint(const Accelerator& accelerator) {
  if (!is_grid(accelerator.structure()) || accelerator.backend() != Backend::cpu)
    throw Error(ErrorCode::invalid_argument,
                "--fingerprint needs a grid structure on --backend cpu");
  const GridView grid = accelerator.grid_view();
  const GridInfo& info = grid.info;
  std::uint64_t hash = 0xcbf29ce484222325ull;
  hash = fnv1a(&info.num_cells, sizeof(info.num_cells), hash);
  hash = grid.compact_cells ? fnv1a(grid.compact_cells,
                                    (std::size_t(info.num_cells) + 1) * sizeof(CompactCell), hash)
                            : fnv1a(grid.cells, std::size_t(info.num_cells) * sizeof(Cell), hash);
  hash = fnv1a(grid.refs, std::size_t(info.num_refs) * sizeof(std::uint32_t), hash);
  return fnv1a(grid.entries, std::size_t(info.num_entries) * sizeof(Entry), hash);
}

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

/// The process's memory per phase: {"phase": {"resident_bytes", "peak_bytes"}}.
nlohmann::json phase_memory_json(const PhaseMemoryRecorder& memory) {
  nlohmann::json phases = nlohmann::json::object();
  for (const PhaseMemory& p : memory.phases())
    phases[to_string(p.phase)] = {{"resident_bytes", p.memory.resident_bytes},
                                  {"peak_bytes", p.memory.peak_bytes}};
  return phases;
}

void print_phase_memory(const PhaseMemoryRecorder& memory) {
  fmt::print("  process memory at each phase's end (resident / peak {}):\n",
             memory.peaks_per_phase() ? "during the phase" : "so far");
  for (const PhaseMemory& p : memory.phases())
    fmt::print("    {:<22} {:>10.1f} / {:>10.1f} MiB\n", to_string(p.phase),
               double(p.memory.resident_bytes) / 1048576.0,
               double(p.memory.peak_bytes) / 1048576.0);
  fmt::print("  process memory peak {:>18.1f} MiB\n",
             double(memory.whole_peak_bytes()) / 1048576.0);
}

void print_statistics(const Scene& scene, const Accelerator& accelerator, const BuildConfig& grid) {
  const BuildStats& stats = accelerator.build_stats();
  fmt::print("{} on {} over {} ({} triangles): built in {:.2f} ms\n",
             to_string(accelerator.structure()), to_string(accelerator.backend()), scene.name,
             scene.triangle_count(), stats.build_ms);
  for (std::size_t p = 0; p < kBuildPhaseCount; ++p) {
    if (!stats.phase_ms[p]) continue;
    fmt::print("  phase {:<22} {:>10.2f} ms", to_string(BuildPhase(p)), *stats.phase_ms[p]);
    if (stats.grid && stats.grid->phase_peak_bytes[p])
      fmt::print(" {:>10.2f} MiB at its peak",
                 double(*stats.grid->phase_peak_bytes[p]) / 1048576.0);
    fmt::print("\n");
  }
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
  PhaseMemoryRecorder memory;
  const auto accelerator = build_reporting(scene, o.structure, &memory);
  print_statistics(scene, *accelerator, o.structure.grid);
  print_phase_memory(memory);
  const std::string fingerprint =
      o.fingerprint ? fmt::format("{:016x}", grid_fingerprint(*accelerator)) : std::string();
  if (o.fingerprint) fmt::print("  grid fingerprint {:>22}\n", fingerprint);
  if (o.json.empty()) return;
  auto statistics = statistics_json(scene, o.scene, *accelerator, o.structure.grid);
  if (o.fingerprint) statistics["grid_fingerprint"] = fingerprint;
  statistics["phase_process_memory"] = phase_memory_json(memory);
  statistics["process_peak_bytes"] = memory.whole_peak_bytes();
  write_file_whole(o.json, statistics.dump(2) + '\n');
}

}  // namespace

void add_build_command(CLI::App& app) {
  auto o = std::make_shared<BuildOptions>();
  auto* cmd = app.add_subcommand("build", "Build a structure and print its statistics");
  cmd->add_option("scene", o->scene, "Scene file or builtin:NAME[:N]")->required();
  add_structure_options(cmd, o->structure);
  cmd->add_option("--json", o->json, "Write the statistics as JSON to this file");
  cmd->add_flag("--fingerprint", o->fingerprint,
                "Print a hash of the grid's cells, references and voxel map (CPU grids)");
  cmd->callback([o] { run_build(*o); });
}

}  // namespace irgrid::cli
