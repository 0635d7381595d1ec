// `irgrid build`: builds a structure and prints its statistics (counts, bytes, phase times).
#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "common.h"
#include "config_json.h"
#include "irgrid/error.h"

namespace irgrid::cli {
namespace {

struct BuildOptions {
  std::string scene, json;
  StructureOptions structure;
};

nlohmann::json statistics_json(const Scene& scene, const std::string& scene_file,
                               const Accelerator& accelerator, const BuildConfig& grid) {
  const BuildInfo& info = accelerator.build_info();
  const double per_triangle =
      scene.triangle_count() ? double(info.memory_bytes) / double(scene.triangle_count()) : 0;
  nlohmann::json statistics = {{"scene", scene.name},
                               {"scene_file", scene_file},
                               {"triangles", scene.triangle_count()},
                               {"structure", accelerator.structure()},
                               {"backend", accelerator.backend()},
                               {"build_ms", info.build_ms},
                               {"build_phases_ms", info.phases_ms},
                               {"counts", info.counts},
                               {"memory_bytes", info.memory_bytes},
                               {"memory_breakdown_bytes", info.bytes},
                               {"bytes_per_triangle", per_triangle}};
  add_grid_config_json(statistics, accelerator.structure(), info, grid);
  return statistics;
}

void print_statistics(const nlohmann::json& s) {
  fmt::print("{} on {} over {} ({} triangles): built in {:.2f} ms\n",
             s["structure"].get<std::string>(), s["backend"].get<std::string>(),
             s["scene"].get<std::string>(), s["triangles"].get<std::uint64_t>(),
             s["build_ms"].get<double>());
  // The phases in the order a grid build runs them (JSON objects sort their keys), then any
  // other structure's.
  const auto& phases = s["build_phases_ms"];
  std::vector<std::string> order(std::begin(kGridBuildPhaseNames), std::end(kGridBuildPhaseNames));
  for (const auto& [phase, ms] : phases.items())
    if (std::find(order.begin(), order.end(), phase) == order.end()) order.push_back(phase);
  for (const auto& phase : order)
    if (phases.contains(phase))
      fmt::print("  phase {:<22} {:>10.2f} ms\n", phase, phases[phase].get<double>());
  if (s.contains("lambda2_used") &&
      s["lambda2_used"].get<double>() != s["config"]["lambda2"].get<double>())
    fmt::print("  lambda2 used {:>26.4g} (raised from {:.4g} to aim at --min-cells {})\n",
               s["lambda2_used"].get<double>(), s["config"]["lambda2"].get<double>(),
               s["config"]["min_cells"].get<unsigned>());
  for (const auto& [name, count] : s["counts"].items())
    if (name != "peak_build_bytes")
      fmt::print("  {:<28} {:>10}\n", name, count.get<std::uint64_t>());
  for (const auto& [name, bytes] : s["memory_breakdown_bytes"].items())
    fmt::print("  bytes {:<22} {:>10.2f} MiB\n", name, bytes.get<double>() / 1048576.0);
  fmt::print("  memory {:>31.2f} MiB ({:.1f} bytes per triangle)\n",
             s["memory_bytes"].get<double>() / 1048576.0, s["bytes_per_triangle"].get<double>());
  if (s["counts"].contains("peak_build_bytes"))
    fmt::print("  peak memory during the build {:>9.2f} MiB\n",
               s["counts"]["peak_build_bytes"].get<double>() / 1048576.0);
}

void run_build(const BuildOptions& o) {
  if (!o.json.empty()) check_writable(o.json);
  const Scene scene = load_scene_reporting(o.scene);
  const auto accelerator = build_reporting(scene, o.structure);
  const auto statistics = statistics_json(scene, o.scene, *accelerator, o.structure.grid);
  print_statistics(statistics);
  if (o.json.empty()) return;
  std::ofstream file(o.json);
  if (!file) throw Error(ErrorCode::io, fmt::format("{}: cannot create", o.json));
  file << statistics.dump(2) << '\n';
  if (!file.flush()) throw Error(ErrorCode::io, fmt::format("{}: write failed", o.json));
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
