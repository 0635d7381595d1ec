// `irgrid rays`: generates the standard rays of a scene view and writes them to a ray file.
#include <fmt/format.h>

#include "commands.h"
#include "common.h"
#include "irgrid/io/rays.h"

namespace irgrid::cli {
namespace {

struct RaysOptions {
  std::string scene, kind = "primary", output, format = "irgrid", views_file;
  StructureOptions structure;
  int view = 0;
  RayConfig config;
};

void run_rays(const RaysOptions& o) {
  const RayKind kind = parse_ray_kind(o.kind);
  const RayFormat format = parse_ray_format(o.format);
  check_writable(o.output);
  const Scene scene = load_scene_reporting(o.scene);
  const Camera camera = pick_view(scene, o.view, o.views_file);
  std::unique_ptr<Accelerator> tracer;
  if (kind == RayKind::ao || kind == RayKind::diffuse) tracer = build_reporting(scene, o.structure);
  const auto rays = generate_rays(scene, camera, kind, o.config, tracer.get());
  write_rays(o.output, rays, format);
  fmt::print("wrote {} {} rays ({} format, {} bytes each) to {}\n", rays.size(), o.kind, o.format,
             format == RayFormat::irgrid ? 32 : 24, o.output);
}

}  // namespace

void add_rays_command(CLI::App& app) {
  auto o = std::make_shared<RaysOptions>();
  auto* cmd =
      app.add_subcommand("rays", "Generate standard rays (primary, ao, diffuse, random) to a file");
  cmd->set_help_flag("--help", "Print this help message and exit");
  cmd->add_option("scene", o->scene, "Scene file or builtin:NAME[:N]")->required();
  cmd->add_option("--kind", o->kind, "primary, ao, diffuse or random")->capture_default_str();
  cmd->add_option("--view", o->view, "Index of the camera in the scene's views")
      ->capture_default_str();
  cmd->add_option("--views-file,--views", o->views_file, "views.json to take the cameras from");
  cmd->add_option("--spp", o->config.spp, "Secondary rays per primary hit (ao, diffuse)")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxSamplesPerHit));
  cmd->add_option("--count", o->config.count, "Number of random rays")
      ->capture_default_str()
      ->check(whole_number(1));
  cmd->add_option("-w,--width", o->config.width, "Image width")
      ->capture_default_str()
      ->check(whole_number(1));
  cmd->add_option("-h,--height", o->config.height, "Image height")
      ->capture_default_str()
      ->check(whole_number(1));
  cmd->add_option("--seed", o->config.seed, "Random seed")->capture_default_str();
  cmd->add_option("-o,--output", o->output, "Ray file to write")->required();
  cmd->add_option("--format", o->format, "irgrid (32 B/ray) or hagrid (24 B/ray)")
      ->capture_default_str();
  add_structure_options(cmd, o->structure);
  cmd->callback([o] { run_rays(*o); });
}

}  // namespace irgrid::cli
