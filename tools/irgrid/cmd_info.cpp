// `irgrid info [SCENE] [--json]`: the build, the machine, and optionally a scene's figures.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "common.h"
#include "irgrid/accelerator.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/machine.h"
#include "irgrid/system.h"

namespace irgrid::cli {
namespace {

struct InfoOptions {
  std::string scene;
  bool json = false;
};

nlohmann::json system_json() {
  const auto machine = machine_info(environment_options().cpu_walk);
  const auto cuda = cuda_status();
  nlohmann::json gpus = nlohmann::json::array(), structures = nlohmann::json::array();
  for (const Structure structure : available_structures())
    structures.push_back(to_string(structure));
  for (const auto& gpu : cuda.gpus)
    gpus.push_back(
        {{"index", gpu.index},
         {"name", gpu.name},
         {"memory_bytes", gpu.memory_bytes},
         {"free_bytes", gpu.free_bytes},
         {"compute_capability", fmt::format("{}.{}", gpu.compute_major, gpu.compute_minor)},
         {"multiprocessors", gpu.multiprocessors}});
  return {{"version", version()},
          {"backends", cuda.compiled ? nlohmann::json{"cpu", "cuda"} : nlohmann::json{"cpu"}},
          {"structures", structures},
          {"cuda_status", cuda.status},
          {"gpus", gpus},
          {"cpu", machine.cpu_model},
          {"hardware_threads", machine.hardware_threads},
          {"threads", machine.tbb_threads},
          {"cpu_walk", machine.cpu_walk},
          {"gather_data_sampling", machine.gather_data_sampling}};
}

nlohmann::json scene_json(const Scene& scene) {
  const auto box = scene.bounds();
  const auto& r = scene.report;
  return {{"name", scene.name},
          {"source", scene.source},
          {"triangles", scene.triangle_count()},
          {"triangles_read", r.triangles_read},
          {"vertices", r.vertices_read},
          {"bounds", {{"min", box.lo}, {"max", box.hi}}},
          {"diagonal", box.diagonal()},
          {"dropped",
           {{"degenerate", r.dropped_degenerate},
            {"nonfinite", r.dropped_nonfinite},
            {"bad_index", r.dropped_bad_index}}},
          {"unknown_statements", r.unknown_statements},
          {"views", scene_views(scene).size()}};
}

void print_system(const nlohmann::json& s) {
  fmt::print("irgrid {}\n", s["version"].get<std::string>());
  fmt::print("backends:   {}\n", fmt::join(s["backends"].get<std::vector<std::string>>(), ", "));
  fmt::print("structures: {}\n", fmt::join(s["structures"].get<std::vector<std::string>>(), ", "));
  fmt::print("cpu:        {} ({} hardware threads, {} used)\n", s["cpu"].get<std::string>(),
             s["hardware_threads"].get<int>(), s["threads"].get<int>());
  fmt::print("cpu walk:   {} (IRGRID_CPU_WALK=avx512|avx2|single|interleaved picks another)\n",
             s["cpu_walk"].get<std::string>());
  const auto gather = s["gather_data_sampling"].get<std::string>();
  if (gather.rfind("Mitigation", 0) == 0)
    fmt::print(
        "note:       gather data sampling: {}. The kernel slows the gather instructions the SIMD "
        "walks rely on; on this CPU compare IRGRID_CPU_WALK=single with the default\n",
        gather);
  fmt::print("cuda:       {}\n", s["cuda_status"].get<std::string>());
  for (const auto& gpu : s["gpus"])
    fmt::print("gpu {}:      {}, {:.1f} GiB ({:.1f} GiB free), compute capability {}, {} SMs\n",
               gpu["index"].get<int>(), gpu["name"].get<std::string>(),
               gpu["memory_bytes"].get<double>() / (1 << 30),
               gpu["free_bytes"].get<double>() / (1 << 30),
               gpu["compute_capability"].get<std::string>(), gpu["multiprocessors"].get<int>());
}

void print_scene(const nlohmann::json& s) {
  fmt::print("scene:      {} ({})\n", s["name"].get<std::string>(), s["source"].get<std::string>());
  fmt::print("triangles:  {} ({} read)\n", s["triangles"].get<std::uint64_t>(),
             s["triangles_read"].get<std::uint64_t>());
  fmt::print("vertices:   {}\n", s["vertices"].get<std::uint64_t>());
  const auto lo = s["bounds"]["min"].get<std::array<float, 3>>();
  const auto hi = s["bounds"]["max"].get<std::array<float, 3>>();
  fmt::print("bounds:     ({:g}, {:g}, {:g}) - ({:g}, {:g}, {:g}), diagonal {:g}\n", lo[0], lo[1],
             lo[2], hi[0], hi[1], hi[2], s["diagonal"].get<float>());
  const auto& d = s["dropped"];
  fmt::print("dropped:    {} degenerate, {} non-finite, {} bad index\n",
             d["degenerate"].get<std::uint64_t>(), d["nonfinite"].get<std::uint64_t>(),
             d["bad_index"].get<std::uint64_t>());
  fmt::print("views:      {}\n", s["views"].get<std::size_t>());
}

void run_info(const InfoOptions& options) {
  nlohmann::json out = system_json();
  if (!options.scene.empty()) out["scene"] = scene_json(load_scene_reporting(options.scene));
  if (options.json) {
    fmt::print("{}\n", out.dump(2));
    return;
  }
  print_system(out);
  if (out.contains("scene")) print_scene(out["scene"]);
  if (options.scene.empty()) {
    fmt::print("built-in scenes:\n");
    for (const auto& [name, description] : builtin_scene_names())
      fmt::print("  builtin:{:<18} {}\n", name, description);
  }
}

}  // namespace

void add_info_command(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  auto* cmd =
      app.add_subcommand("info", "Version, backends, GPUs, threads; with a scene: its figures");
  cmd->add_option("scene", options->scene, "Scene file or builtin:NAME[:N]");
  cmd->add_flag("--json", options->json, "Print JSON on stdout instead of text");
  cmd->callback([options] { run_info(*options); });
}

}  // namespace irgrid::cli
